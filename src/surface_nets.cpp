// SPDX-License-Identifier: Apache-2.0
#include "osteon/volume.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include "core/release.hpp"
#include "surface_internal.hpp"

// Based on: S. F. Frisken, "SurfaceNets for multi-label segmentations with preservation of sharp
// boundaries", Journal of Computer Graphics Techniques 11(1), 2022 (one vertex per cell shared by
// every label, quads dual to the voxel faces between two labels, smoothing constrained to the
// cell, junction lines smoothed only along themselves); S. F. F. Gibson, "Constrained elastic
// surface nets", MICCAI 1998; G. Taubin, "A signal processing approach to fair surface design",
// SIGGRAPH 1995 (the alternating smoothing steps that do not shrink). The per-label vertex
// splitting that makes each surface manifold is osteon's: sheets of a cell found by connectivity
// across the cell's faces, ambiguous faces resolved as in 6-connected digital topology (Kong &
// Rosenfeld, "Digital topology", CVGIP 48, 1989), with the one exception drawn at `joined_faces`.
//
// Frame: voxel (i, j, k) has its centre at index coordinates (i, j, k). A cell is the cube
// between 8 voxel centres; the volume is padded by one voxel of background on every side, so
// the cells are numbered by their upper corner, (cx, cy, cz) in [0, nx] x [0, ny] x [0, nz], and
// cell (cx, cy, cz) spans [cx - 1, cx] x [cy - 1, cy] x [cz - 1, cz]. A row is the cells of one
// (cy, cz); row r = cz * (ny + 1) + cy. Cells are stored in row order, each row by cx.

namespace osteon {
namespace {

using detail::kNotSelected;
using detail::LabelNet;

// ---- the cube between 8 voxel centres ----------------------------------------------------------
//
//          6 ---------- 7         corner c = dx + 2 dy + 4 dz
//         /|           /|         edges 0-3 run along x at (dy, dz) = (e & 1, e >> 1),
//        / |          / |               4-7 along y at (dx, dz), 8-11 along z at (dx, dy)
//       4 ---------- 5  |         faces 2 axis + side: 0 -x, 1 +x, 2 -y, 3 +y, 4 -z, 5 +z
//       |  2 --------|- 3
//       | /          | /   z
//       |/           |/    |  y
//       0 ---------- 1     | /
//                          |/___ x
//
// A label L's surface crosses the cell's edges with one corner in L. Its sheets in the cell are
// the groups of crossed edges connected across the cell's faces; on a face, the crossed edges
// pair up around the corners they cut off:
//
//     one L corner       two L corners, adjacent     two L corners, diagonal (ambiguous)
//      N ----- N           N ----- N                   L --\  /-- N      separating: the pairs go
//      |       |           |       |                   |    \/    |      round the L corners, so L
//      \       |           --------|                   |    /\    |      is 6-connected (the
//      L\----- N           L ----- L                   N --/  \-- L      default)
//
// Each sheet is a closed loop of crossed edges on the cube, so a disc: one vertex of L's mesh.

constexpr uint8_t kNoSheet = 0xFF;
constexpr int kVariantsPerMask = 7;  // variant = mask * 7 + (0, or f + 1: face f joins L)

struct CubeTables {
  std::array<std::array<uint8_t, 4>, 6> face_corners{};  // in cyclic order
  std::array<std::array<uint8_t, 4>, 6> face_edges{};    // edge k joins corners k and k + 1
  /// Bit f: face f holds two diagonal corners of the mask, and they are connected through the
  /// other corners of the cube by cube edges. At most one bit is ever set: such a path uses
  /// three corners of the opposite face and both vertical neighbours, leaving no face
  /// ambiguous but f.
  std::array<uint8_t, 256> joined_faces{};
  /// [variant][edge]: the sheet the edge's crossing belongs to, kNoSheet where the edge is not
  /// crossed; [variant][12]: the number of sheets.
  std::vector<std::array<uint8_t, 13>> sheets;
};

int edge_between(int a, int b) {
  if (a > b) std::swap(a, b);
  switch (b - a) {
    case 1:
      return ((a >> 1) & 1) + 2 * (a >> 2);
    case 2:
      return 4 + (a & 1) + 2 * (a >> 2);
    default:
      return 8 + (a & 1) + 2 * ((a >> 1) & 1);
  }
}

/// The corners of cube edge e: the lower one, and it plus the edge's axis.
std::pair<int, int> edge_corners(int e) {
  const int axis = e / 4, u = e & 1, v = (e >> 1) & 1;  // u, v: the other two axes
  const int a = axis == 0 ? 2 * u + 4 * v : axis == 1 ? u + 4 * v : u + 2 * v;
  return {a, a + (1 << axis)};
}

// Whether corners `from` and `to` are connected through corners of `mask` by cube edges.
bool connected_in_cube(unsigned mask, int from, int to) {
  unsigned seen = 1u << from, frontier = seen;
  while (frontier != 0) {
    unsigned next = 0;
    for (int c = 0; c < 8; ++c) {
      if ((frontier >> c & 1) == 0) continue;
      for (int axis = 0; axis < 3; ++axis) {
        int n = c ^ (1 << axis);
        if ((mask >> n & 1) != 0 && (seen >> n & 1) == 0) next |= 1u << n;
      }
    }
    seen |= next;
    frontier = next;
  }
  return (seen >> to & 1) != 0;
}

std::array<uint8_t, 13> group_sheets(const CubeTables& t, unsigned mask, int joined_face) {
  std::array<uint8_t, 12> parent;
  for (uint8_t e = 0; e < 12; ++e) parent[e] = e;
  auto find = [&](int e) {
    while (parent[e] != e) e = parent[e];
    return e;
  };
  auto unite = [&](int a, int b) {
    a = find(a), b = find(b);
    if (a != b) parent[std::max(a, b)] = uint8_t(std::min(a, b));
  };
  for (int f = 0; f < 6; ++f) {
    const auto& q = t.face_corners[f];
    const auto& e = t.face_edges[f];
    bool in[4];
    for (int k = 0; k < 4; ++k) in[k] = (mask >> q[k] & 1) != 0;
    int crossed[4], n = 0;
    for (int k = 0; k < 4; ++k) {
      if (in[k] != in[(k + 1) % 4]) crossed[n++] = e[k];
    }
    if (n == 2) {
      unite(crossed[0], crossed[1]);
    } else if (n == 4) {
      // Ambiguous: pair the edges round each L corner (separating them), or, on the joined
      // face, round each other corner.
      const bool round_inside = f != joined_face;
      for (int k = 0; k < 4; ++k) {
        if (in[k] == round_inside) unite(e[(k + 3) % 4], e[k]);
      }
    }
  }
  std::array<uint8_t, 13> out;
  out.fill(kNoSheet);
  uint8_t count = 0;
  std::array<uint8_t, 12> sheet_of_root;
  sheet_of_root.fill(kNoSheet);
  for (int e = 0; e < 12; ++e) {
    const auto [a, b] = edge_corners(e);
    if ((mask >> a & 1) == (mask >> b & 1)) continue;
    int root = find(e);
    if (sheet_of_root[root] == kNoSheet) sheet_of_root[root] = count++;
    out[e] = sheet_of_root[root];
  }
  out[12] = count;
  return out;
}

const CubeTables& cube_tables() {
  static const CubeTables tables = [] {
    CubeTables t;
    for (int f = 0; f < 6; ++f) {
      int s = f & 1;
      std::array<int, 4> q;
      if (f / 2 == 0) q = {s, s + 2, s + 6, s + 4};
      if (f / 2 == 1) q = {2 * s, 2 * s + 1, 2 * s + 5, 2 * s + 4};
      if (f / 2 == 2) q = {4 * s, 4 * s + 1, 4 * s + 3, 4 * s + 2};
      for (int k = 0; k < 4; ++k) {
        t.face_corners[f][k] = uint8_t(q[k]);
        t.face_edges[f][k] = uint8_t(edge_between(q[k], q[(k + 1) % 4]));
      }
    }
    for (unsigned mask = 0; mask < 256; ++mask) {
      for (int f = 0; f < 6; ++f) {
        const auto& q = t.face_corners[f];
        bool in[4];
        for (int k = 0; k < 4; ++k) in[k] = (mask >> q[k] & 1) != 0;
        if (in[0] != in[2] || in[1] != in[3] || in[0] == in[1]) continue;  // not diagonal
        int from = in[0] ? q[0] : q[1], to = in[0] ? q[2] : q[3];
        if (connected_in_cube(mask, from, to)) t.joined_faces[mask] |= uint8_t(1u << f);
      }
      assert(std::popcount(unsigned{t.joined_faces[mask]}) <= 1);
    }
    t.sheets.resize(256 * kVariantsPerMask);
    for (unsigned mask = 0; mask < 256; ++mask) {
      for (int v = 0; v < kVariantsPerMask; ++v) {
        t.sheets[mask * kVariantsPerMask + v] = group_sheets(t, mask, v - 1);
      }
    }
    return t;
  }();
  return tables;
}

// ---- the voxels
// ----------------------------------------------------------------------------------

struct Grid {
  const uint8_t* bytes = nullptr;
  int bytes_per_voxel = 1;
  int64_t nx = 0, ny = 0, nz = 0;

  /// The dense id of voxel (i, j, k); 0 outside the volume.
  uint32_t at(int64_t i, int64_t j, int64_t k) const {
    if (i < 0 || j < 0 || k < 0 || i >= nx || j >= ny || k >= nz) return 0;
    size_t index = size_t(i + nx * (j + ny * k));
    return bytes_per_voxel == 1 ? bytes[index]
                                : uint32_t(bytes[2 * index]) | uint32_t(bytes[2 * index + 1]) << 8;
  }
};

/// Voxel slice k into `slice`, padded by one background voxel on every side: voxel (i, j) at
/// (i + 1) + (nx + 2) * (j + 1). Slices outside the volume are all background.
template <class T>
void fill_slice(const Grid& grid, int64_t k, std::vector<T>& slice) {
  std::fill(slice.begin(), slice.end(), T{0});
  if (k < 0 || k >= grid.nz) return;
  const size_t width = size_t(grid.nx) + 2;
  for (int64_t j = 0; j < grid.ny; ++j) {
    T* row = &slice[size_t(j + 1) * width + 1];
    const uint8_t* src =
        grid.bytes + size_t(grid.bytes_per_voxel) * size_t(grid.nx * (j + grid.ny * k));
    if constexpr (sizeof(T) == 1) {
      std::memcpy(row, src, size_t(grid.nx));
    } else {
      for (int64_t i = 0; i < grid.nx; ++i) row[i] = T(src[2 * i] | src[2 * i + 1] << 8);
    }
  }
}

// ---- pass 1: the surface cells -----------------------------------------------------------------

constexpr uint32_t kSlabsPerChunk = 4;  // work unit; fixed, so results do not depend on threads

/// The cells one chunk of slabs found, in row order.
struct Chunk {
  std::vector<uint32_t> row_cells;  ///< cells in each of the chunk's rows
  std::vector<uint32_t> x;          ///< cx
  std::vector<uint8_t> smooth;      ///< faces whose neighbours the cell is smoothed with
  std::vector<uint8_t> entries;     ///< selected labels in the cell
  std::vector<uint16_t> entry_label, entry_variant;
  std::vector<uint32_t> entry_vertex;  ///< first sheet vertex, counted from the chunk's first
  uint64_t vertices = 0;
};

struct ScanContext {
  Grid grid;
  const std::vector<uint32_t>* output_of = nullptr;  // dense id -> output index
  const CubeTables* tables = nullptr;
};

/// The faces to smooth a cell's position with (Frisken's constraint): a cell on no junction line
/// (no face holds three regions) moves towards all its neighbours across faces between regions;
/// a cell a junction line passes through (two faces hold three or more regions) only along the
/// line, so the line stays sharp; a cell where junction lines meet or end stays put.
uint8_t smoothing_faces(uint8_t faces, uint8_t junctions) {
  if (junctions == 0) return faces;
  return std::popcount(unsigned{junctions}) == 2 ? junctions : 0;
}

/// Corner c of cell (cx, cy, cz) as voxel coordinates.
std::array<int64_t, 3> corner_voxel(int64_t cx, int64_t cy, int64_t cz, int c) {
  return {cx - 1 + (c & 1), cy - 1 + ((c >> 1) & 1), cz - 1 + (c >> 2)};
}

/// The variant of label `id` (corners `mask`) in cell (cx, cy, cz): an ambiguous face is
/// separating unless it is joined in this cell and in the cell across it. Then the label's
/// surface would pass the face twice between the same two cell vertices (two diagonal voxels
/// whose label loops round the edge between them through both cells: a handle with no room
/// in its hole), which no manifold mesh can hold; that face joins the label instead. The
/// decision is the same seen from either cell, and the other corners of the face are then never
/// connected in either cell (they would cross the joining path on the cube), so the joined face
/// is manifold too.
uint16_t label_variant(const ScanContext& ctx, unsigned mask, uint32_t id, int64_t cx, int64_t cy,
                       int64_t cz) {
  unsigned joined = ctx.tables->joined_faces[mask];
  int join = 0;
  if (joined != 0) {
    int f = std::countr_zero(joined);
    int64_t d[3] = {0, 0, 0};
    d[f / 2] = (f & 1) != 0 ? 1 : -1;
    unsigned across = 0;
    for (int c = 0; c < 8; ++c) {
      auto v = corner_voxel(cx + d[0], cy + d[1], cz + d[2], c);
      if (ctx.grid.at(v[0], v[1], v[2]) == id) across |= 1u << c;
    }
    if ((ctx.tables->joined_faces[across] >> (f ^ 1) & 1) != 0) join = f + 1;
  }
  return uint16_t(mask * kVariantsPerMask + join);
}

template <class T>
void scan_cell(const ScanContext& ctx, const T (&l)[8], uint32_t cx, uint32_t cy, uint32_t cz,
               Chunk& out) {
  const CubeTables& t = *ctx.tables;
  uint8_t faces = 0, junctions = 0;
  for (int f = 0; f < 6; ++f) {
    const auto& q = t.face_corners[f];
    T a = l[q[0]], b = l[q[1]], c = l[q[2]], d = l[q[3]];
    int regions = 1 + (b != a) + (c != a && c != b) + (d != a && d != b && d != c);
    if (regions > 1) faces |= uint8_t(1u << f);
    if (regions > 2) junctions |= uint8_t(1u << f);
  }
  uint8_t entries = 0;
  unsigned done = 0;
  for (int c = 0; c < 8; ++c) {
    if ((done >> c & 1) != 0) continue;
    unsigned mask = 0;
    for (int k = c; k < 8; ++k) mask |= unsigned{l[k] == l[c]} << k;
    done |= mask;
    if ((*ctx.output_of)[l[c]] == kNotSelected) continue;
    uint16_t variant = label_variant(ctx, mask, l[c], cx, cy, cz);
    out.entry_label.push_back(l[c]);
    out.entry_variant.push_back(variant);
    out.entry_vertex.push_back(uint32_t(out.vertices));
    out.vertices += t.sheets[variant][12];
    ++entries;
  }
  if (entries == 0) return;  // only unselected labels here
  out.x.push_back(cx);
  out.smooth.push_back(smoothing_faces(faces, junctions));
  out.entries.push_back(entries);
  ++out.row_cells.back();
}

/// Slab cz: the cells between voxel slices cz - 1 (lo) and cz (hi).
template <class T>
void scan_slab(const ScanContext& ctx, const T* lo, const T* hi, uint32_t cz,
               std::vector<uint8_t>& differs, Chunk& out) {
  const size_t nx = size_t(ctx.grid.nx), ny = size_t(ctx.grid.ny), width = nx + 2;
  for (size_t cy = 0; cy <= ny; ++cy) {
    out.row_cells.push_back(0);
    const T* r0 = lo + cy * width;
    const T* r1 = r0 + width;
    const T* r2 = hi + cy * width;
    const T* r3 = r2 + width;
    // Vectorizable: which cells have two different corners.
    for (size_t x = 0; x <= nx; ++x) {
      T v = r0[x];
      T d = T((r0[x + 1] ^ v) | (r1[x] ^ v) | (r1[x + 1] ^ v) | (r2[x] ^ v) | (r2[x + 1] ^ v) |
              (r3[x] ^ v) | (r3[x + 1] ^ v));
      differs[x] = d != 0;
    }
    for (size_t x = 0; x <= nx; ++x) {
      if (differs[x] == 0) continue;
      const T l[8] = {r0[x], r0[x + 1], r1[x], r1[x + 1], r2[x], r2[x + 1], r3[x], r3[x + 1]};
      scan_cell(ctx, l, uint32_t(x), uint32_t(cy), cz, out);
    }
  }
}

template <class T>
void scan_chunk(const ScanContext& ctx, uint32_t cz_begin, uint32_t cz_end, Chunk& out) {
  const size_t slice = size_t(ctx.grid.nx + 2) * size_t(ctx.grid.ny + 2);
  std::vector<T> lo(slice), hi(slice);
  std::vector<uint8_t> differs(size_t(ctx.grid.nx) + 1);
  fill_slice(ctx.grid, int64_t(cz_begin) - 1, lo);
  for (uint32_t cz = cz_begin; cz < cz_end; ++cz) {
    fill_slice(ctx.grid, cz, hi);
    scan_slab(ctx, lo.data(), hi.data(), cz, differs, out);
    std::swap(lo, hi);
  }
}

/// Every surface cell of the volume, in row order.
struct Cells {
  uint32_t nx = 0, ny = 0, nz = 0;
  std::vector<uint32_t> row_begin;  ///< first cell of each row; one more entry at the end
  std::vector<uint32_t> x;
  std::vector<uint8_t> smooth;
  std::vector<uint32_t> entry_begin;  ///< first entry of each cell; one more at the end
  std::vector<uint16_t> entry_label, entry_variant;
  std::vector<uint32_t> entry_vertex;
  uint32_t vertices = 0;

  size_t rows_per_slab() const { return size_t(ny) + 1; }
  size_t count() const { return x.size(); }

  /// The cell at cx in row `row`; it must be there.
  uint32_t find(size_t row, uint32_t cx) const {
    auto begin = x.begin() + row_begin[row], end = x.begin() + row_begin[row + 1];
    auto it = std::lower_bound(begin, end, cx);
    assert(it != end && *it == cx);
    return uint32_t(it - x.begin());
  }
  /// The vertex of label `id`'s sheet through cube edge `edge` of cell `cell`.
  uint32_t vertex(uint32_t cell, uint32_t id, int edge, const CubeTables& t) const {
    for (uint32_t e = entry_begin[cell]; e < entry_begin[cell + 1]; ++e) {
      if (entry_label[e] != id) continue;
      uint8_t sheet = t.sheets[entry_variant[e]][edge];
      assert(sheet != kNoSheet);
      return entry_vertex[e] + sheet;
    }
    assert(false && "label missing from a cell its quad passes");
    return 0;
  }
};

Status gather_cells(std::vector<Chunk>& chunks, Cells& cells) {
  uint64_t total_cells = 0, total_entries = 0, total_vertices = 0;
  for (const Chunk& c : chunks) {
    total_cells += c.x.size();
    total_entries += c.entry_label.size();
    total_vertices += c.vertices;
  }
  if (total_cells >= UINT32_MAX || total_entries >= UINT32_MAX || total_vertices >= UINT32_MAX) {
    return Status(ErrorCode::kUnsupported,
                  "extract_surfaces: over 2^32 surface vertices; extract fewer labels at a time");
  }
  cells.row_begin.reserve(size_t(cells.nz + 1) * cells.rows_per_slab() + 1);
  cells.x.reserve(total_cells);
  cells.smooth.reserve(total_cells);
  cells.entry_begin.reserve(total_cells + 1);
  cells.entry_label.reserve(total_entries);
  cells.entry_variant.reserve(total_entries);
  cells.entry_vertex.reserve(total_entries);
  uint32_t cell = 0, entry = 0, vertex = 0;
  for (Chunk& c : chunks) {
    for (uint32_t n : c.row_cells) {
      cells.row_begin.push_back(cell);
      cell += n;
    }
    for (uint8_t n : c.entries) {
      cells.entry_begin.push_back(entry);
      entry += n;
    }
    cells.x.insert(cells.x.end(), c.x.begin(), c.x.end());
    cells.smooth.insert(cells.smooth.end(), c.smooth.begin(), c.smooth.end());
    cells.entry_label.insert(cells.entry_label.end(), c.entry_label.begin(), c.entry_label.end());
    cells.entry_variant.insert(cells.entry_variant.end(), c.entry_variant.begin(),
                               c.entry_variant.end());
    for (uint32_t v : c.entry_vertex) cells.entry_vertex.push_back(vertex + v);
    vertex += uint32_t(c.vertices);
    c = Chunk{};  // free as we go
  }
  cells.row_begin.push_back(cell);
  cells.entry_begin.push_back(entry);
  cells.vertices = vertex;
  return Status::ok_status();
}

// ---- pass 2: constrained smoothing -----------------------------------------------------------

/// How far inside its cell a position stays, in voxels: positions of neighbouring cells never
/// meet, so no triangle collapses and the sheets of two cells never touch.
constexpr float kCellMargin = 1.0f / 32;
/// Taubin's two steps: even passes move a position 0.7 of the way to its neighbours' mean,
/// odd passes 0.75 of the way back, so the surface is smoothed without shrinking. Measured on
/// voxelized spheres: plain Laplacian passes (0.5 of the way, 16 of them) take 15 % of the
/// volume off a sphere of radius 5 voxels and 5.6 % off radius 10; these keep radius 10 within
/// 1.4 % of the analytic volume (the voxels themselves hold 0.8 % more), with vertices on
/// average 0.11 voxel from the sphere.
constexpr float kTowards = 0.7f, kAway = -0.75f;

/// The neighbours across faces 2..5 (-y, +y, -z, +z) of every cell, 4 slots a cell (faces 0 and
/// 1 are the previous and next cell of the row). A neighbour that is not stored (it holds only
/// unselected labels) is dropped from the cell's smoothing faces.
std::vector<uint32_t> find_neighbours(Cells& cells) {
  std::vector<uint32_t> neighbours(4 * cells.count(), 0);
  const size_t rows = cells.row_begin.size() - 1, per_slab = cells.rows_per_slab();
  tbb::parallel_for(
      tbb::blocked_range<size_t>(0, rows, 64), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t row = range.begin(); row < range.end(); ++row) {
          for (uint32_t c = cells.row_begin[row]; c < cells.row_begin[row + 1]; ++c) {
            uint8_t keep = cells.smooth[c];
            for (int f = 0; f < 6; ++f) {
              if ((keep >> f & 1) == 0) continue;
              uint32_t cx = cells.x[c];
              // The neighbouring row, and whether the cell must be the previous or next one.
              bool found = false;
              uint32_t n = 0;
              if (f < 2) {
                uint32_t want = f == 0 ? cx - 1 : cx + 1;
                n = f == 0 ? c - 1 : c + 1;
                found =
                    n >= cells.row_begin[row] && n < cells.row_begin[row + 1] && cells.x[n] == want;
              } else {
                size_t other = f == 2   ? row - 1
                               : f == 3 ? row + 1
                               : f == 4 ? row - per_slab
                                        : row + per_slab;
                auto begin = cells.x.begin() + cells.row_begin[other];
                auto end = cells.x.begin() + cells.row_begin[other + 1];
                auto it = std::lower_bound(begin, end, cx);
                found = it != end && *it == cx;
                n = uint32_t(it - cells.x.begin());
                if (found) neighbours[4 * size_t(c) + size_t(f - 2)] = n;
              }
              if (!found) keep &= uint8_t(~(1u << f));
            }
            cells.smooth[c] = keep;
          }
        }
      });
  return neighbours;
}

/// The offset of the neighbour's cell across face f, as it moves positions into this cell's frame.
constexpr float kFaceOffset[6][3] = {{-1, 0, 0}, {1, 0, 0},  {0, -1, 0},
                                     {0, 1, 0},  {0, 0, -1}, {0, 0, 1}};

/// Each cell's position relative to its cell's lower corner, in [margin, 1 - margin]^3:
/// `iterations` passes, each moving every position by kTowards or kAway of the way to the mean
/// of its smoothing neighbours (all at once, from the previous pass), then clamping it into its
/// cell.
std::vector<Vec3> smooth_positions(const Cells& cells, const std::vector<uint32_t>& neighbours,
                                   int iterations) {
  const size_t n = cells.count();
  std::vector<Vec3> from(n, Vec3{0.5f, 0.5f, 0.5f}), to(n);
  for (int it = 0; it < iterations; ++it) {
    const float factor = it % 2 == 0 ? kTowards : kAway;
    tbb::parallel_for(
        tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t>& range) {
          for (size_t c = range.begin(); c < range.end(); ++c) {
            const uint8_t faces = cells.smooth[c];
            const Vec3 p = from[c];
            if (faces == 0) {
              to[c] = p;
              continue;
            }
            float sx = 0, sy = 0, sz = 0;
            for (int f = 0; f < 6; ++f) {
              if ((faces >> f & 1) == 0) continue;
              size_t m = f == 0 ? c - 1 : f == 1 ? c + 1 : neighbours[4 * c + size_t(f - 2)];
              sx += from[m].x + kFaceOffset[f][0];
              sy += from[m].y + kFaceOffset[f][1];
              sz += from[m].z + kFaceOffset[f][2];
            }
            const float inv = 1.0f / float(std::popcount(unsigned{faces}));
            auto step = [&](float at, float sum) {
              float moved = at + factor * (sum * inv - at);
              return std::clamp(moved, kCellMargin, 1.0f - kCellMargin);
            };
            to[c] = Vec3{step(p.x, sx), step(p.y, sy), step(p.z, sz)};
          }
        });
    std::swap(from, to);
  }
  return from;
}

/// World positions of the cells (transform_point of the index position, rounded once to float).
std::vector<Vec3> world_positions(const Cells& cells, const std::vector<Vec3>& local,
                                  const Mat4& index_to_world) {
  std::vector<Vec3> world(cells.count());
  const size_t rows = cells.row_begin.size() - 1, per_slab = cells.rows_per_slab();
  tbb::parallel_for(
      tbb::blocked_range<size_t>(0, rows, 64), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t row = range.begin(); row < range.end(); ++row) {
          const double cy = double(row % per_slab) - 1, cz = double(row / per_slab) - 1;
          for (uint32_t c = cells.row_begin[row]; c < cells.row_begin[row + 1]; ++c) {
            Vec3d p{double(cells.x[c]) - 1 + local[c].x, cy + local[c].y, cz + local[c].z};
            world[c] = to_float(transform_point(index_to_world, p));
          }
        }
      });
  return world;
}

// ---- pass 3: the quads -------------------------------------------------------------------------

/// Triangles one chunk emitted, per output label: 3 vertex ids of the label's mesh each, and the
/// region on the other side.
struct ChunkTriangles {
  std::vector<std::vector<uint32_t>> corners;
  std::vector<std::vector<uint32_t>> other;
};

/// Whether triangle (a, b, c) has no area (its cross product is exactly zero, as
/// is_degenerate_triangle decides).
bool zero_area(const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const Vec3d n = cross(b - a, c - a);
  return n.x == 0 && n.y == 0 && n.z == 0;
}

struct EmitContext {
  Grid grid;
  const Cells* cells = nullptr;
  const std::vector<Vec3>* world = nullptr;
  const std::vector<uint32_t>* local_id = nullptr;  ///< cell vertex -> its label mesh's vertex
  const std::vector<uint32_t>* output_of = nullptr;
  const CubeTables* tables = nullptr;
  bool mirrored = false;
};

/// The quads of slabs [cz_begin, cz_end). Each voxel face between two regions is emitted once,
/// by the cell whose corner 0 is the face's lower voxel p: for the face between p and
/// q = p + axis, the four cells round segment pq in counter-clockwise order seen from q (so the
/// quad faces out of p), with pq's edge number in each:
///
///     axis x: (cy-1, cz-1) e3, (cy, cz-1) e2, (cy, cz) e0, (cy-1, cz) e1
///     axis y: (cx-1, cz-1) e7, (cx-1, cz) e5, (cx, cz) e4, (cx, cz-1) e6
///     axis z: (cx-1, cy-1) e11, (cx, cy-1) e10, (cx, cy) e8, (cx-1, cy) e9
///
/// Each quad is cut along its shorter diagonal in world space, once, and both labels get the
/// same two triangles, oppositely wound.
void emit_chunk(const EmitContext& ctx, uint32_t cz_begin, uint32_t cz_end, ChunkTriangles& out) {
  const Cells& cells = *ctx.cells;
  const std::vector<Vec3>& world = *ctx.world;
  const size_t per_slab = cells.rows_per_slab();
  static constexpr int kEdges[3][4] = {{3, 2, 0, 1}, {7, 5, 4, 6}, {11, 10, 8, 9}};
  for (uint32_t cz = cz_begin; cz < cz_end; ++cz) {
    for (size_t cy = 0; cy < per_slab; ++cy) {
      const size_t row = cz * per_slab + cy;
      for (uint32_t c = cells.row_begin[row]; c < cells.row_begin[row + 1]; ++c) {
        const int64_t i = int64_t(cells.x[c]) - 1, j = int64_t(cy) - 1, k = int64_t(cz) - 1;
        const uint32_t a = ctx.grid.at(i, j, k);
        // The neighbours below, found once a cell when a quad needs them.
        uint32_t below_y = UINT32_MAX, below_z = UINT32_MAX, below_yz = UINT32_MAX;
        auto cell_y = [&] {
          if (below_y == UINT32_MAX) below_y = cells.find(row - 1, cells.x[c]);
          return below_y;
        };
        auto cell_z = [&] {
          if (below_z == UINT32_MAX) below_z = cells.find(row - per_slab, cells.x[c]);
          return below_z;
        };
        auto cell_yz = [&] {
          if (below_yz == UINT32_MAX) below_yz = cells.find(row - per_slab - 1, cells.x[c]);
          return below_yz;
        };
        for (int axis = 0; axis < 3; ++axis) {
          const uint32_t b = ctx.grid.at(i + (axis == 0), j + (axis == 1), k + (axis == 2));
          if (a == b) continue;
          const uint32_t oa = (*ctx.output_of)[a], ob = (*ctx.output_of)[b];
          if (oa == kNotSelected && ob == kNotSelected) continue;
          uint32_t quad[4];
          if (axis == 0) quad[0] = cell_yz(), quad[1] = cell_z(), quad[2] = c, quad[3] = cell_y();
          if (axis == 1) quad[0] = cell_z() - 1, quad[1] = c - 1, quad[2] = c, quad[3] = cell_z();
          if (axis == 2) quad[0] = cell_y() - 1, quad[1] = cell_y(), quad[2] = c, quad[3] = c - 1;
          const Vec3d p0 = to_double(world[quad[0]]), p1 = to_double(world[quad[1]]);
          const Vec3d p2 = to_double(world[quad[2]]), p3 = to_double(world[quad[3]]);
          bool cut02 = squared_length(p2 - p0) <= squared_length(p3 - p1);
          // Unless that cut leaves a triangle of no area (three cells in a line, as along a
          // straight junction line) and the other does not.
          const bool flat02 = zero_area(p0, p1, p2) || zero_area(p0, p2, p3);
          const bool flat13 = zero_area(p0, p1, p3) || zero_area(p1, p2, p3);
          if (flat02 != flat13) cut02 = flat13;
          static constexpr int kCut02[6] = {0, 1, 2, 0, 2, 3}, kCut13[6] = {0, 1, 3, 1, 2, 3};
          const int* tri = cut02 ? kCut02 : kCut13;
          // Label a's triangles face out of a: counter-clockwise as listed unless the world
          // transform mirrors. Label b's are the same triangles with corners 1 and 2 swapped.
          for (int side = 0; side < 2; ++side) {
            const uint32_t id = side == 0 ? a : b, o = side == 0 ? oa : ob;
            if (o == kNotSelected) continue;
            uint32_t v[4];
            for (int q = 0; q < 4; ++q)
              v[q] = (*ctx.local_id)[cells.vertex(quad[q], id, kEdges[axis][q], *ctx.tables)];
            const bool flip = (side == 1) != ctx.mirrored;
            std::vector<uint32_t>& dst = out.corners[o];
            for (int t = 0; t < 6; t += 3) {
              dst.push_back(v[tri[t]]);
              dst.push_back(v[tri[t + (flip ? 2 : 1)]]);
              dst.push_back(v[tri[t + (flip ? 1 : 2)]]);
              out.other[o].push_back(side == 0 ? b : a);
            }
          }
        }
      }
    }
  }
}

// ---- split vertices -----------------------------------------------------------------------------

/// How far apart the vertices of a split cell move: each group towards the mean of its crossed
/// edges' midpoints, by this fraction of its offset from the mean of all of them (about 0.1
/// voxel each for two voxels touching by an edge).
constexpr float kSplitShift = 0.3f;

/// The positions (index coordinates in the cell, like `local`) of the vertices of cell `c`, in
/// entry and sheet order, where some label has several sheets there. Vertices that share a
/// quad of two selected labels share one position (their meshes share the boundary); the groups
/// of vertices that share none move apart, so a label's sheets stay distinct points (welding a
/// mesh by position keeps it manifold) unless a selected label touches two of them in the cell.
void split_positions(const Cells& cells, uint32_t c, const int64_t (&corner0)[3], const Grid& grid,
                     const CubeTables& t, const Vec3& local, std::vector<Vec3>& out) {
  const uint32_t eb = cells.entry_begin[c], ee = cells.entry_begin[c + 1];
  uint32_t base[9] = {0};
  for (uint32_t e = eb; e < ee; ++e)
    base[e - eb + 1] = base[e - eb] + t.sheets[cells.entry_variant[e]][12];
  const uint32_t slots = base[ee - eb];
  uint8_t parent[32];
  for (uint8_t k = 0; k < 32; ++k) parent[k] = k;
  auto find = [&](int k) {
    while (parent[k] != k) k = parent[k];
    return k;
  };
  float sum[32][3] = {}, count[32] = {};
  int entry_of_corner[8];
  for (int k = 0; k < 8; ++k) {
    const uint32_t id =
        grid.at(corner0[0] + (k & 1), corner0[1] + ((k >> 1) & 1), corner0[2] + (k >> 2));
    entry_of_corner[k] = -1;
    for (uint32_t e = eb; e < ee; ++e) {
      if (cells.entry_label[e] == id) entry_of_corner[k] = int(e - eb);
    }
  }
  for (int edge = 0; edge < 12; ++edge) {
    const auto [a, b] = edge_corners(edge);
    const int ea = entry_of_corner[a], eb2 = entry_of_corner[b];
    if (ea == eb2) continue;  // the same label, or both unselected: not crossed for any mesh
    int slot[2] = {-1, -1};
    const int ends[2] = {ea, eb2};
    for (int side = 0; side < 2; ++side) {
      if (ends[side] < 0) continue;
      const uint8_t sheet = t.sheets[cells.entry_variant[eb + uint32_t(ends[side])]][edge];
      slot[side] = int(base[ends[side]] + sheet);
      sum[slot[side]][0] += 0.5f * float((a & 1) + (b & 1));
      sum[slot[side]][1] += 0.5f * float(((a >> 1) & 1) + ((b >> 1) & 1));
      sum[slot[side]][2] += 0.5f * float((a >> 2) + (b >> 2));
      count[slot[side]] += 1;
    }
    if (slot[0] >= 0 && slot[1] >= 0) {
      const int x = find(slot[0]), y = find(slot[1]);
      if (x != y) parent[std::max(x, y)] = uint8_t(std::min(x, y));
    }
  }
  float group_sum[32][3] = {}, group_count[32] = {}, all[3] = {0, 0, 0}, all_count = 0;
  int groups = 0;
  for (uint32_t k = 0; k < slots; ++k) {
    const int g = find(int(k));
    groups += g == int(k);
    for (int i = 0; i < 3; ++i) group_sum[g][i] += sum[k][i], all[i] += sum[k][i];
    group_count[g] += count[k];
    all_count += count[k];
  }
  out.assign(slots, local);
  if (groups < 2) return;
  for (uint32_t k = 0; k < slots; ++k) {
    const int g = find(int(k));
    float p[3] = {local.x, local.y, local.z};
    for (int i = 0; i < 3; ++i) {
      const float shift = kSplitShift * (group_sum[g][i] / group_count[g] - all[i] / all_count);
      p[i] = std::clamp(p[i] + shift, kCellMargin, 1.0f - kCellMargin);
    }
    out[k] = Vec3{p[0], p[1], p[2]};
  }
}

// ---- assembly -----------------------------------------------------------------------------------

std::string label_name(const LabelVolume& volume, uint32_t value) {
  for (const VolumeLabel& label : volume.table) {
    if (label.value == value && !label.name.empty()) return label.name;
  }
  return "label " + std::to_string(value);
}

Status check_input(const LabelVolume& volume, const SurfaceOptions& options) {
  if (volume.bytes_per_voxel != 1 && volume.bytes_per_voxel != 2) {
    return Status(ErrorCode::kInvalidArgument, "extract_surfaces: bytes_per_voxel must be 1 or 2");
  }
  if (volume.voxels.size() != volume.voxel_count() * size_t(volume.bytes_per_voxel)) {
    return Status(ErrorCode::kInvalidArgument,
                  "extract_surfaces: " + std::to_string(volume.voxels.size()) +
                      " voxel bytes for a volume of " + std::to_string(volume.voxel_count()) +
                      " voxels");
  }
  if (volume.values.empty() || volume.values[0] != 0) {
    return Status(ErrorCode::kInvalidArgument, "extract_surfaces: values[0] must be 0");
  }
  if (options.smoothing_iterations < 0 || options.threads < 0 ||
      !(options.precision >= 0 && std::isfinite(options.precision))) {
    return Status(ErrorCode::kInvalidArgument,
                  "extract_surfaces: smoothing_iterations and threads must be >= 0, precision a "
                  "finite number >= 0");
  }
  const double det = determinant3(volume.index_to_world);
  if (!(std::isfinite(det) && det != 0)) {
    return Status(ErrorCode::kInvalidArgument,
                  "extract_surfaces: index_to_world is singular or not finite");
  }
  return Status::ok_status();
}

/// The dense ids to extract, in output order: options.labels' values (each once) or every id.
Result<std::vector<uint32_t>> selected_ids(const LabelVolume& volume,
                                           const SurfaceOptions& options) {
  std::vector<uint32_t> ids;
  if (options.labels.empty()) {
    for (uint32_t d = 1; d < volume.values.size(); ++d) ids.push_back(d);
    return ids;
  }
  for (uint32_t value : options.labels) {
    auto it = value == 0 ? volume.values.end()
                         : std::find(volume.values.begin() + 1, volume.values.end(), value);
    if (it == volume.values.end()) {
      return Status(ErrorCode::kInvalidArgument,
                    (volume.source.empty() ? std::string("extract_surfaces") : volume.source) +
                        ": label " + std::to_string(value) + " is not present in the volume");
    }
    uint32_t d = uint32_t(it - volume.values.begin());
    if (std::find(ids.begin(), ids.end(), d) == ids.end()) ids.push_back(d);
  }
  return ids;
}

template <class F>
void for_each_chunk(size_t chunks, F&& f) {
  tbb::parallel_for(
      tbb::blocked_range<size_t>(0, chunks, 1),
      [&](const tbb::blocked_range<size_t>& range) {
        for (size_t c = range.begin(); c < range.end(); ++c) f(c);
      },
      tbb::simple_partitioner());
}

Result<std::vector<LabelSurface>> extract_in_arena(const LabelVolume& volume,
                                                   const SurfaceOptions& options,
                                                   detail::SimplifyReport* report,
                                                   std::vector<std::vector<uint32_t>>* sides) {
  OSTEON_RETURN_IF_ERROR(check_input(volume, options));
  auto ids = selected_ids(volume, options);
  if (!ids.ok()) return ids.status();
  const CubeTables& tables = cube_tables();

  std::vector<uint32_t> output_of(volume.bytes_per_voxel == 1 ? 256 : 65536, kNotSelected);
  for (size_t o = 0; o < ids->size(); ++o) output_of[(*ids)[o]] = uint32_t(o);

  Grid grid{volume.voxels.data(), volume.bytes_per_voxel, volume.size[0], volume.size[1],
            volume.size[2]};
  Cells cells;
  cells.nx = volume.size[0], cells.ny = volume.size[1], cells.nz = volume.size[2];
  const uint32_t slabs = cells.nz + 1;
  const size_t chunk_count =
      volume.voxel_count() == 0 ? 0 : (slabs + kSlabsPerChunk - 1) / kSlabsPerChunk;
  auto chunk_range = [&](size_t c) {
    return std::pair<uint32_t, uint32_t>(
        uint32_t(c * kSlabsPerChunk),
        std::min<uint32_t>(slabs, uint32_t((c + 1) * kSlabsPerChunk)));
  };

  // Pass 1: the surface cells, two voxel slices at a time.
  {
    std::vector<Chunk> chunks(chunk_count);
    ScanContext scan{grid, &output_of, &tables};
    for_each_chunk(chunk_count, [&](size_t c) {
      auto [begin, end] = chunk_range(c);
      if (volume.bytes_per_voxel == 1) {
        scan_chunk<uint8_t>(scan, begin, end, chunks[c]);
      } else {
        scan_chunk<uint16_t>(scan, begin, end, chunks[c]);
      }
    });
    OSTEON_RETURN_IF_ERROR(gather_cells(chunks, cells));
  }

  // Pass 2: one position a cell, smoothed, then in world coordinates.
  std::vector<Vec3> local, world;
  {
    std::vector<uint32_t> neighbours;
    if (options.smoothing_iterations > 0) neighbours = find_neighbours(cells);
    local = smooth_positions(cells, neighbours, options.smoothing_iterations);
    world = world_positions(cells, local, volume.index_to_world);
  }

  // Each label's vertices in cell order, then its triangles renumbered. The vertex arrays are
  // sized first: growing them by doubling would take the peak over twice the labels' bytes.
  std::vector<LabelNet> nets(ids->size());
  {
    std::vector<size_t> vertices(ids->size(), 0);
    for (size_t e = 0; e < cells.entry_label.size(); ++e) {
      vertices[output_of[cells.entry_label[e]]] += tables.sheets[cells.entry_variant[e]][12];
    }
    for (size_t o = 0; o < nets.size(); ++o) nets[o].mesh.positions.reserve(vertices[o]);
  }
  std::vector<uint32_t> local_id(cells.vertices);
  std::vector<Vec3> split;
  const size_t per_slab = cells.rows_per_slab();
  for (size_t row = 0; row + 1 < cells.row_begin.size(); ++row) {
    for (uint32_t c = cells.row_begin[row]; c < cells.row_begin[row + 1]; ++c) {
      const uint32_t eb = cells.entry_begin[c], ee = cells.entry_begin[c + 1];
      bool splits = false;
      for (uint32_t e = eb; e < ee; ++e) splits |= tables.sheets[cells.entry_variant[e]][12] > 1;
      if (splits) {
        const int64_t corner0[3] = {int64_t(cells.x[c]) - 1, int64_t(row % per_slab) - 1,
                                    int64_t(row / per_slab) - 1};
        split_positions(cells, c, corner0, grid, tables, local[c], split);
        for (Vec3& p : split) {
          p = to_float(transform_point(
              volume.index_to_world,
              Vec3d{corner0[0] + double(p.x), corner0[1] + double(p.y), corner0[2] + double(p.z)}));
        }
      }
      uint32_t slot = 0;
      for (uint32_t e = eb; e < ee; ++e) {
        Mesh& mesh = nets[output_of[cells.entry_label[e]]].mesh;
        const uint32_t sheets = tables.sheets[cells.entry_variant[e]][12];
        for (uint32_t s = 0; s < sheets; ++s, ++slot) {
          local_id[cells.entry_vertex[e] + s] = uint32_t(mesh.positions.size());
          mesh.positions.push_back(splits ? split[slot] : world[c]);
        }
      }
    }
  }
  detail::release(local);

  // Pass 3: the quads, per chunk and label.
  std::vector<ChunkTriangles> emitted(chunk_count);
  {
    EmitContext emit{grid,       &cells,     &world,  &local_id,
                     &output_of, &tables, determinant3(volume.index_to_world) < 0};
    for_each_chunk(chunk_count, [&](size_t c) {
      auto [begin, end] = chunk_range(c);
      emitted[c].corners.resize(ids->size());
      emitted[c].other.resize(ids->size());
      emit_chunk(emit, begin, end, emitted[c]);
    });
  }

  detail::release(world);
  detail::release(local_id);
  cells = {};
  for_each_chunk(nets.size(), [&](size_t o) {
    LabelNet& net = nets[o];
    size_t corners = 0;
    for (const ChunkTriangles& chunk : emitted) corners += chunk.corners[o].size();
    net.mesh.indices.reserve(corners);
    net.other.reserve(corners / 3);
    for (ChunkTriangles& chunk : emitted) {
      net.mesh.indices.insert(net.mesh.indices.end(), chunk.corners[o].begin(),
                              chunk.corners[o].end());
      net.other.insert(net.other.end(), chunk.other[o].begin(), chunk.other[o].end());
      detail::release(chunk.corners[o]);
      detail::release(chunk.other[o]);
    }
  });
  detail::release(emitted);

  std::vector<uint64_t> extracted(nets.size());
  for (size_t o = 0; o < nets.size(); ++o) {
    nets[o].id = (*ids)[o];
    extracted[o] = nets[o].mesh.triangle_count();
  }
  detail::SimplifyReport simplified;
  if (options.precision > 0) simplified = detail::simplify_nets(nets, output_of, options.precision);
  if (report != nullptr) *report = simplified;

  if (sides != nullptr) {
    sides->assign(nets.size(), {});
    for (size_t o = 0; o < nets.size(); ++o) {
      for (uint32_t id : nets[o].other) (*sides)[o].push_back(volume.values[id]);
    }
  }
  std::vector<LabelSurface> surfaces(nets.size());
  for (size_t o = 0; o < nets.size(); ++o) {
    LabelSurface& s = surfaces[o];
    s.value = volume.values[nets[o].id];
    s.mesh = std::move(nets[o].mesh);
    s.mesh.name = label_name(volume, s.value);
    s.mesh.source = volume.source;
    s.mesh.unit = Unit::kMillimetre;
    s.mesh.stored_vertices = s.mesh.positions.size();
    s.triangles_extracted = extracted[o];
  }
  return surfaces;
}

}  // namespace

namespace detail {

Result<std::vector<LabelSurface>> extract_surfaces(const LabelVolume& volume,
                                                   const SurfaceOptions& options,
                                                   SimplifyReport* report,
                                                   std::vector<std::vector<uint32_t>>* sides) {
  const int cores = tbb::info::default_concurrency();
  tbb::task_arena arena(options.threads > 0 ? std::min(options.threads, cores) : cores);
  return arena.execute([&] { return extract_in_arena(volume, options, report, sides); });
}

}  // namespace detail

Result<std::vector<LabelSurface>> extract_surfaces(const LabelVolume& volume,
                                                   const SurfaceOptions& options) {
  return detail::extract_surfaces(volume, options, nullptr);
}

}  // namespace osteon
