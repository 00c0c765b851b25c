// SPDX-License-Identifier: Apache-2.0
#include <tbb/blocked_range.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numeric>
#include <string>
#include <unordered_set>
#include <vector>

#include "osteon/io.hpp"
#include "osteon/volume.hpp"
#include "volume_write_internal.hpp"

// Based on: Nooruddin & Turk, "Simplification and repair of polygonal models using volumetric
// techniques" (IEEE TVCG 2003): a voxel is inside when rays from it cross the surface an odd
// number of times, decided by a vote over several directions, so that a hole that corrupts one
// ray leaves the majority right (here three rays, along x, y and z, two votes of three). Each ray
// runs through a column of voxel centres, as in scan-line rasterisation: the triangle's
// projection is tested against the column with Pineda's edge functions (Pineda 1988), evaluated
// exactly in integers, and a column that passes exactly through an edge or a vertex is given to
// the triangles that hold the column moved by (e, e^2) for an infinitesimal e (simulation of
// simplicity, Edelsbrunner & Muecke 1990; the "top-left" fill rule of Direct3D and OpenGL is
// this rule), so a closed surface is crossed an even number of times along every column,
// whatever the column hits.
//
// Instead of sorting each column's hits, a hit toggles one bit, at the first voxel centre at or
// beyond it, and a running XOR along the axis turns the toggles into parities: word-wise along x
// (a prefix XOR within each 64-bit word), row by row along y and plane by plane along z.

namespace osteon {

namespace {

/// Vertex coordinates are fixed-point, 2^16 steps a voxel (8 nm at 0.5 mm): integer edge functions
/// are then exact (coordinates below 2^48, products below 2^98 in 128 bits), and voxel centres
/// are exact multiples of kStep.
constexpr int kStepBits = 16;
constexpr int64_t kStep = int64_t{1} << kStepBits;

using Int3 = std::array<int64_t, 3>;
using Wide = __int128;

int64_t floor_steps(int64_t q) {
  return q >> kStepBits;  // arithmetic shift: floor for negative values too
}
int64_t ceil_steps(int64_t q) {
  return -((-q) >> kStepBits);
}

struct Grid {
  Vec3d origin{0, 0, 0};
  double voxel = 1;
  std::array<uint32_t, 3> size{0, 0, 0};
};

/// One bit per voxel of a box: voxel (x, y, z) of the box is bit x % 64 of word
/// row(y, z) + x / 64; rows are padded to whole words.
struct BitBox {
  std::array<uint32_t, 3> lo{0, 0, 0};    ///< the box's first voxel in the grid
  std::array<uint32_t, 3> size{0, 0, 0};  ///< voxels a side; 0: empty
  size_t words_per_row = 0;
  std::vector<uint64_t> bits;

  size_t row(size_t y, size_t z) const { return (y + size_t{size[1]} * z) * words_per_row; }
  void toggle(size_t x, size_t y, size_t z) { bits[row(y, z) + x / 64] ^= uint64_t{1} << (x % 64); }
  bool test(size_t x, size_t y, size_t z) const {
    return (bits[row(y, z) + x / 64] >> (x % 64)) & 1;
  }
};

/// Twice the signed area of (a, b, p) projected on the axes u and w: > 0 when p lies to the left
/// of a -> b.
Wide orient(const Int3& a, const Int3& b, int64_t pu, int64_t pw, int u, int w) {
  return Wide(b[u] - a[u]) * (pw - a[w]) - Wide(b[w] - a[w]) * (pu - a[u]);
}

/// Whether a column through p is inside the counter-clockwise edge a -> b, given the edge
/// function `o` of p: strictly left of it, or on it and the column moved by (e, e^2) is left of it,
/// which is when the edge runs downwards (dw < 0) or, horizontal, to the right (du > 0).
bool inside_edge(Wide o, const Int3& a, const Int3& b, int u, int w) {
  if (o != 0) return o > 0;
  int64_t du = b[u] - a[u], dw = b[w] - a[w];
  return dw < 0 || (dw == 0 && du > 0);
}

/// Toggles, for each crossing of the triangles with the columns along `axis`, the bit of the
/// first voxel centre at or beyond the crossing.
void toggle_crossings(const std::vector<Int3>& q, const std::vector<uint32_t>& indices, int axis,
                      BitBox& box) {
  const int u = (axis + 1) % 3, w = (axis + 2) % 3;
  const int64_t n[3] = {box.size[0], box.size[1], box.size[2]};
  for (size_t t = 0; t + 2 < indices.size(); t += 3) {
    const Int3* a = &q[indices[t]];
    const Int3* b = &q[indices[t + 1]];
    const Int3* c = &q[indices[t + 2]];
    Wide area = orient(*a, *b, (*c)[u], (*c)[w], u, w);
    if (area == 0) continue;  // edge-on: no column moved by (e, e^2) is inside it
    if (area < 0) {
      std::swap(b, c);
      area = -area;
    }
    int64_t u0 = std::max<int64_t>(0, ceil_steps(std::min({(*a)[u], (*b)[u], (*c)[u]})));
    int64_t u1 = std::min<int64_t>(n[u] - 1, floor_steps(std::max({(*a)[u], (*b)[u], (*c)[u]})));
    int64_t w0 = std::max<int64_t>(0, ceil_steps(std::min({(*a)[w], (*b)[w], (*c)[w]})));
    int64_t w1 = std::min<int64_t>(n[w] - 1, floor_steps(std::max({(*a)[w], (*b)[w], (*c)[w]})));
    const double inverse_area = 1.0 / double(area);
    const double ab = double((*b)[axis] - (*a)[axis]), ac = double((*c)[axis] - (*a)[axis]);
    for (int64_t iw = w0; iw <= w1; ++iw) {
      for (int64_t iu = u0; iu <= u1; ++iu) {
        const int64_t pu = iu * kStep, pw = iw * kStep;
        if (!inside_edge(orient(*b, *c, pu, pw, u, w), *b, *c, u, w)) continue;
        const Wide eb = orient(*c, *a, pu, pw, u, w);
        if (!inside_edge(eb, *c, *a, u, w)) continue;
        const Wide ec = orient(*a, *b, pu, pw, u, w);
        if (!inside_edge(ec, *a, *b, u, w)) continue;
        // The crossing, from a along the barycentric weights of b and c (exact for a face
        // perpendicular to the axis: ab = ac = 0).
        double at = double((*a)[axis]) + (double(eb) * ab + double(ec) * ac) * inverse_area;
        double k = std::ceil(at / double(kStep));
        if (k >= double(n[axis])) continue;
        int64_t kk = std::max<int64_t>(0, int64_t(k));
        int64_t cell[3];
        cell[axis] = kk;
        cell[u] = iu;
        cell[w] = iw;
        box.toggle(size_t(cell[0]), size_t(cell[1]), size_t(cell[2]));
      }
    }
  }
}

/// Turns toggles into parities along `axis` (a running XOR): bit (x, y, z) is then set when the
/// column crosses the surface an odd number of times up to and including the voxel centre.
void accumulate_parity(int axis, BitBox& box) {
  const size_t rows = size_t{box.size[1]} * box.size[2];
  const size_t plane = box.words_per_row * box.size[1];
  uint64_t* bits = box.bits.data();
  if (axis == 0) {
    for (size_t r = 0; r < rows; ++r) {
      uint64_t carry = 0;
      for (size_t i = r * box.words_per_row; i < (r + 1) * box.words_per_row; ++i) {
        uint64_t v = bits[i];
        v ^= v << 1;
        v ^= v << 2;
        v ^= v << 4;
        v ^= v << 8;
        v ^= v << 16;
        v ^= v << 32;
        if (carry) v = ~v;
        carry = v >> 63;
        bits[i] = v;
      }
    }
  } else if (axis == 1) {
    for (size_t z = 0; z < box.size[2]; ++z) {
      for (size_t y = 1; y < box.size[1]; ++y) {
        uint64_t* row = bits + box.row(y, z);
        const uint64_t* before = row - box.words_per_row;
        for (size_t i = 0; i < box.words_per_row; ++i) row[i] ^= before[i];
      }
    }
  } else {
    for (size_t z = 1; z < box.size[2]; ++z) {
      uint64_t* now = bits + z * plane;
      const uint64_t* before = now - plane;
      for (size_t i = 0; i < plane; ++i) now[i] ^= before[i];
    }
  }
}

/// Where the part is thinner than a voxel, or runs between the voxel centres, the inside test
/// leaves it few voxels or none, and its surface would come back far from where it was (or not at
/// all). So the surface is sampled at most a voxel apart per axis, and a sample whose grid cells
/// (the voxel centres round it) hold none of the part's inside voxels is thin. Thin samples,
/// nearest their voxel centre first, each set the voxel nearest them unless it, or a neighbour
/// along the axis nearest the triangle's normal, is set already: a sheet thinner than a voxel
/// gets one layer of voxels, not one for each face. Every sample then has one of the part's
/// voxels within a cell and a half, and a vertex of the extracted surface near it. The voxels set
/// join the part's inside (a later part's inside takes them, as for any voxel inside two parts).
/// `q` is in box-relative steps.
void mark_thin_regions(const std::vector<Int3>& q, const std::vector<uint32_t>& indices,
                       BitBox& box) {
  const int64_t n[3] = {box.size[0], box.size[1], box.size[2]};
  auto set = [&](int64_t x, int64_t y, int64_t z) {
    return x >= 0 && y >= 0 && z >= 0 && x < n[0] && y < n[1] && z < n[2] &&
           box.test(size_t(x), size_t(y), size_t(z));
  };
  // The voxel centres of the grid cells that hold the point (2 per axis; 3 where the point is
  // on a centre's plane, between two cells).
  auto any_in_cells = [&](const int64_t (&p)[3]) {
    int64_t lo[3], hi[3];
    for (int axis = 0; axis < 3; ++axis) {
      lo[axis] = ceil_steps(p[axis]) - 1;
      hi[axis] = floor_steps(p[axis]) + 1;
    }
    for (int64_t z = lo[2]; z <= hi[2]; ++z)
      for (int64_t y = lo[1]; y <= hi[1]; ++y)
        for (int64_t x = lo[0]; x <= hi[0]; ++x)
          if (set(x, y, z)) return true;
    return false;
  };
  struct Sample {
    double distance;  ///< squared, in steps, to the nearest voxel centre
    int64_t voxel[3];
    int axis;  ///< the axis nearest the triangle's normal
  };
  std::vector<Sample> thin;
  for (size_t t = 0; t + 2 < indices.size(); t += 3) {
    const Int3& a = q[indices[t]];
    const Int3& b = q[indices[t + 1]];
    const Int3& c = q[indices[t + 2]];
    int64_t longest = 0;
    for (int axis = 0; axis < 3; ++axis) {
      longest = std::max({longest, std::abs(b[axis] - a[axis]), std::abs(c[axis] - b[axis]),
                          std::abs(a[axis] - c[axis])});
    }
    const Vec3d normal = cross(Vec3d{double(b[0] - a[0]), double(b[1] - a[1]), double(b[2] - a[2])},
                               Vec3d{double(c[0] - a[0]), double(c[1] - a[1]), double(c[2] - a[2])});
    const double m[3] = {std::abs(normal.x), std::abs(normal.y), std::abs(normal.z)};
    const int axis = m[0] >= m[1] && m[0] >= m[2] ? 0 : (m[1] >= m[2] ? 1 : 2);
    // Samples on a triangular lattice of `steps` intervals a side: under a voxel apart per axis.
    const int64_t steps = std::max<int64_t>(1, (longest + kStep - 1) / kStep);
    for (int64_t i = 0; i <= steps; ++i) {
      for (int64_t j = 0; i + j <= steps; ++j) {
        const double wb = double(i) / double(steps), wc = double(j) / double(steps);
        int64_t p[3];
        Sample sample{0, {0, 0, 0}, axis};
        bool inside = true;
        for (int k = 0; k < 3; ++k) {
          p[k] = a[k] + std::llround(wb * double(b[k] - a[k]) + wc * double(c[k] - a[k]));
          sample.voxel[k] = floor_steps(p[k] + kStep / 2);
          const double d = double(p[k] - sample.voxel[k] * kStep);
          sample.distance += d * d;
          inside &= sample.voxel[k] >= 0 && sample.voxel[k] < n[k];
        }
        if (inside && !any_in_cells(p)) thin.push_back(sample);
      }
    }
  }
  std::sort(thin.begin(), thin.end(),
            [](const Sample& x, const Sample& y) { return x.distance < y.distance; });
  for (const Sample& sample : thin) {
    const int64_t* v = sample.voxel;
    int64_t below[3] = {v[0], v[1], v[2]}, above[3] = {v[0], v[1], v[2]};
    --below[sample.axis];
    ++above[sample.axis];
    if (set(v[0], v[1], v[2]) || set(below[0], below[1], below[2]) ||
        set(above[0], above[1], above[2]))
      continue;
    box.toggle(size_t(v[0]), size_t(v[1]), size_t(v[2]));
  }
}

/// The voxels of `grid` inside `part`, in the part's own box (the voxel centres within its
/// bounding box and one more on every side): parity along x, y and z, two votes of three, and
/// the thin regions' voxels.
BitBox voxelize_part(const Mesh& part, const Grid& grid) {
  BitBox box;
  if (part.indices.empty()) return box;
  std::vector<Int3> q(part.positions.size(), Int3{0, 0, 0});
  std::vector<char> used(part.positions.size(), 0);
  for (uint32_t i : part.indices) used[i] = 1;
  Int3 qmin{0, 0, 0}, qmax{0, 0, 0};
  bool first = true;
  const double origin[3] = {grid.origin.x, grid.origin.y, grid.origin.z};
  for (size_t v = 0; v < q.size(); ++v) {
    if (!used[v]) continue;
    const Vec3& p = part.positions[v];
    const double c[3] = {p.x, p.y, p.z};
    for (int a = 0; a < 3; ++a) {
      q[v][a] = std::llround((c[a] - origin[a]) / grid.voxel * double(kStep));
      qmin[a] = first ? q[v][a] : std::min(qmin[a], q[v][a]);
      qmax[a] = first ? q[v][a] : std::max(qmax[a], q[v][a]);
    }
    first = false;
  }
  std::array<int64_t, 3> lo{}, hi{};
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::max<int64_t>(0, ceil_steps(qmin[a]) - 1);
    hi[a] = std::min<int64_t>(int64_t{grid.size[a]} - 1, floor_steps(qmax[a]) + 1);
    if (lo[a] > hi[a]) return box;  // no voxel centre within the part's box
  }
  for (size_t v = 0; v < q.size(); ++v) {
    for (int a = 0; a < 3; ++a) q[v][a] -= lo[a] * kStep;
  }
  for (int a = 0; a < 3; ++a) {
    box.lo[a] = uint32_t(lo[a]);
    box.size[a] = uint32_t(hi[a] - lo[a] + 1);
  }
  box.words_per_row = (size_t{box.size[0]} + 63) / 64;
  const size_t words = box.words_per_row * box.size[1] * box.size[2];

  BitBox votes[3] = {box, box, box};
  for (int axis = 0; axis < 3; ++axis) {
    votes[axis].bits.assign(words, 0);
    toggle_crossings(q, part.indices, axis, votes[axis]);
    accumulate_parity(axis, votes[axis]);
  }
  box.bits = std::move(votes[0].bits);
  const uint64_t* y = votes[1].bits.data();
  const uint64_t* z = votes[2].bits.data();
  for (size_t i = 0; i < words; ++i) {
    uint64_t x = box.bits[i];
    box.bits[i] = (x & y[i]) | (z[i] & (x | y[i]));
  }
  if (box.size[0] % 64 != 0) {
    const uint64_t keep = (uint64_t{1} << (box.size[0] % 64)) - 1;
    for (size_t r = 0; r < size_t{box.size[1]} * box.size[2]; ++r)
      box.bits[(r + 1) * box.words_per_row - 1] &= keep;
  }
  mark_thin_regions(q, part.indices, box);
  return box;
}

/// The label names: each part's name, its last path component without a mesh file's extension,
/// made unique by a suffix (a label table may not give two labels one name).
std::vector<std::string> label_names(const Scene& parts) {
  std::vector<std::string> names;
  std::unordered_set<std::string> taken;
  for (size_t k = 0; k < parts.parts.size(); ++k) {
    std::string name = parts.parts[k].name;
    size_t slash = name.find_last_of("/\\");
    if (slash != std::string::npos) name = name.substr(slash + 1);
    size_t dot = name.rfind('.');
    if (dot != std::string::npos && dot > 0 && format_from_extension(name) != Format::kUnknown)
      name = name.substr(0, dot);
    if (name.empty()) name = "part " + std::to_string(k + 1);
    std::string unique = name;
    for (int n = 2; taken.count(unique) != 0; ++n) unique = name + " " + std::to_string(n);
    taken.insert(unique);
    names.push_back(unique);
  }
  return names;
}

Status check_parts(const Scene& parts, const std::string& path) {
  for (size_t k = 0; k < parts.parts.size(); ++k) {
    const Mesh& mesh = parts.parts[k];
    auto bad = [&](const std::string& what) {
      return error(ErrorCode::kInvalidArgument, path,
                   "part " + std::to_string(k) + " (" + mesh.name + "): " + what);
    };
    if (mesh.indices.size() % 3 != 0) return bad("indices are not whole triangles");
    for (uint32_t i : mesh.indices) {
      if (i >= mesh.positions.size()) return bad("a triangle refers to a missing vertex");
    }
    for (const Vec3& p : mesh.positions) {
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        return bad("a vertex has a NaN or infinite coordinate");
    }
  }
  return Status();
}

/// The grid: origin at the parts' box minimum less `margin` voxels, ceil(extent / voxel) +
/// 2 * margin + 1 voxels a side.
Result<Grid> make_grid(const Scene& parts, const VoxelizeOptions& options,
                       const std::string& path) {
  Aabb all;
  for (const Mesh& mesh : parts.parts) {
    if (!mesh.indices.empty()) expand(all, bounding_box(mesh));
  }
  if (all.empty) return error(ErrorCode::kInvalidArgument, path, "no triangles to voxelize");
  Grid grid;
  grid.voxel = options.voxel;
  const double lo[3] = {all.min.x, all.min.y, all.min.z};
  const double hi[3] = {all.max.x, all.max.y, all.max.z};
  double origin[3];
  for (int a = 0; a < 3; ++a) {
    origin[a] = lo[a] - double(options.margin) * options.voxel;
    double n = std::ceil((hi[a] - lo[a]) / options.voxel) + 2.0 * options.margin + 1;
    if (!(n <= double(uint64_t{1} << 31)))
      return error(
          ErrorCode::kInvalidArgument, path,
          "the grid would be over 2^31 voxels a side at " + std::to_string(options.voxel) + " mm");
    grid.size[a] = uint32_t(n);
  }
  grid.origin = {origin[0], origin[1], origin[2]};
  return grid;
}

/// Writes the labels of z-slices [k0, k1) into `slab`; returns how many voxels are labelled.
uint64_t fill_slab(const std::vector<BitBox>& boxes, const Grid& grid, int bytes_per_voxel,
                   uint32_t k0, uint32_t k1, uint8_t* slab) {
  const size_t nx = grid.size[0], ny = grid.size[1];
  for (size_t k = 0; k < boxes.size(); ++k) {
    const BitBox& box = boxes[k];
    if (box.bits.empty()) continue;
    const uint32_t z0 = std::max(k0, box.lo[2]), z1 = std::min(k1, box.lo[2] + box.size[2]);
    const uint16_t label = uint16_t(k + 1);
    for (uint32_t z = z0; z < z1; ++z) {
      for (uint32_t y = 0; y < box.size[1]; ++y) {
        const uint64_t* row = box.bits.data() + box.row(y, z - box.lo[2]);
        const size_t base = box.lo[0] + nx * (box.lo[1] + y + ny * (z - k0));
        for (size_t i = 0; i < box.words_per_row; ++i) {
          for (uint64_t word = row[i]; word != 0; word &= word - 1) {
            const size_t at = base + 64 * i + size_t(std::countr_zero(word));
            if (bytes_per_voxel == 1)
              slab[at] = uint8_t(label);
            else
              std::memcpy(slab + 2 * at, &label, 2);
          }
        }
      }
    }
  }
  const size_t voxels = nx * ny * (k1 - k0);
  uint64_t labelled = 0;
  if (bytes_per_voxel == 1) {
    for (size_t i = 0; i < voxels; ++i) labelled += slab[i] != 0;
  } else {
    for (size_t i = 0; i < voxels; ++i) labelled += (slab[2 * i] | slab[2 * i + 1]) != 0;
  }
  return labelled;
}

}  // namespace

Status voxelize(const Scene& parts, const std::string& path, const VoxelizeOptions& options,
                VoxelizeReport* report) {
  const auto start = std::chrono::steady_clock::now();
  if (!(options.voxel > 0) || !std::isfinite(options.voxel))
    return error(
        ErrorCode::kInvalidArgument, path,
        "the voxel size must be a positive number of mm, not " + std::to_string(options.voxel));
  if (parts.parts.size() > 0xffff)
    return error(ErrorCode::kInvalidArgument, path,
                 std::to_string(parts.parts.size()) + " parts: a label volume holds at most 65535");
  OSTEON_RETURN_IF_ERROR(check_parts(parts, path));
  OSTEON_ASSIGN_OR_RETURN(Grid grid, make_grid(parts, options, path));

  detail::LabelVolumeLayout layout;
  layout.size = grid.size;
  layout.index_to_world = {grid.voxel,
                           0,
                           0,
                           0,
                           0,
                           grid.voxel,
                           0,
                           0,
                           0,
                           0,
                           grid.voxel,
                           0,
                           grid.origin.x,
                           grid.origin.y,
                           grid.origin.z,
                           1};
  layout.bytes_per_voxel = parts.parts.size() <= 0xff ? 1 : 2;
  std::vector<std::string> names = label_names(parts);
  for (size_t k = 0; k < names.size(); ++k) {
    VolumeLabel label;
    label.value = uint32_t(k + 1);
    label.name = names[k];
    layout.labels.push_back(label);
  }
  // Opened first: a missing folder or a bad extension fails before the work.
  detail::NiftiLabelWriter out;
  OSTEON_RETURN_IF_ERROR(out.open(path, layout));

  // Largest parts first, so that the last part to start is a small one.
  std::vector<size_t> order(parts.parts.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return parts.parts[a].indices.size() > parts.parts[b].indices.size();
  });
  std::vector<BitBox> boxes(parts.parts.size());
  const int cores = tbb::info::default_concurrency();
  tbb::task_arena arena(options.threads > 0 ? std::min(options.threads, cores) : cores);
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, order.size(), 1),
                      [&](const tbb::blocked_range<size_t>& range) {
                        for (size_t i = range.begin(); i < range.end(); ++i)
                          boxes[order[i]] = voxelize_part(parts.parts[order[i]], grid);
                      });
  });

  const uint32_t slices = detail::NiftiLabelWriter::slab_slices(layout);
  std::vector<uint8_t> slab;
  uint64_t labelled = 0;
  for (uint32_t k0 = 0; k0 < grid.size[2]; k0 += slices) {
    const uint32_t k1 = std::min(grid.size[2], k0 + slices);
    slab.assign(size_t{grid.size[0]} * grid.size[1] * (k1 - k0) * size_t(layout.bytes_per_voxel),
                0);
    labelled += fill_slab(boxes, grid, layout.bytes_per_voxel, k0, k1, slab.data());
    OSTEON_RETURN_IF_ERROR(out.write(slab.data(), slab.size()));
  }
  OSTEON_RETURN_IF_ERROR(out.commit());
  if (report) {
    report->size = grid.size;
    report->voxels = uint64_t{grid.size[0]} * grid.size[1] * grid.size[2];
    report->labelled = labelled;
    report->ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  }
  return Status();
}

}  // namespace osteon
