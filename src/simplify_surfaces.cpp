// SPDX-License-Identifier: Apache-2.0
#include "surface_internal.hpp"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include <meshoptimizer.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include "osteon/hausdorff.hpp"

// Based on: M. Garland, P. Heckbert, "Surface simplification using quadric error metrics",
// SIGGRAPH 1997, as meshoptimizer's meshopt_simplify implements it (A. Kapoulkine), run on each
// patch between two regions with the patch's border locked, the way multi-material surfaces are
// simplified without opening gaps between the materials; P. Cignoni et al., "Metro", 1998, for
// the sampled distance check.
//
// A label L's surface is cut into patches by the region on the other side (background, an
// unselected label, or a selected label M). A patch between L and M is one piece of surface that
// both meshes hold (oppositely wound): it is simplified once and given to both, so they still
// share it vertex for vertex. The patch's border (where three regions meet) is locked, and
// meshopt_simplify only ever removes vertices, so every patch meeting at a border keeps the
// same border vertices at the same positions.
//
// A patch's vertices are the pairs (L's vertex, M's vertex): where L's surface splits a cell's
// vertex in two and M's does not (or the other way), the patch holds both, so one simplified
// patch maps back onto both meshes. The split appears to meshopt as a border (locked) or as
// coincident vertices (which it locks), so the split survives.
//
// meshopt_simplify checks neither the link condition (a collapse can fold two edges onto one,
// most often into a pair of back-to-back triangles, which are removed) nor how far the removed
// vertices end up from the result (its error is a quadric: a one-voxel spike goes at no cost).
// So each simplified patch is checked: a manifold with the same border, no triangle of zero
// area, no ear folded over the border onto the neighbouring patch, no closed piece turned inside
// out, every extracted vertex within the precision of the simplified patch and sample points of
// every simplified triangle within the precision of the extracted one. Round each place that
// fails, the extracted triangles are frozen (kept as they are, their edges a locked border too)
// and the patch is simplified again, freezing wider rings each round, until it passes.
// Known approximation: the distance check is sampled (like hausdorff()), so the Hausdorff
// distance can exceed the precision a little.

namespace osteon::detail {
namespace {

/// meshopt_simplify's error bound, as a fraction of the precision. Larger bounds leave more
/// places that fail the distance check, and each round of freezing makes meshopt collapse
/// differently elsewhere; measured on spheres of 5 to 40 voxels and on smooth and noisy blobs
/// (0.4 to 0.7), 0.5 leaves the fewest triangles once every check passes.
constexpr double kErrorFactor = 0.5;
/// Rounds of freezing before a patch is given up and kept whole as extracted.
constexpr int kFreezeRounds = 5;
/// A border vertex where the extracted patch's angles add up to more than this (half a turn and
/// 15 degrees) may not be left with one triangle (see shape_defects). Along a straight border
/// the angles add up to about half a turn, and an ear there is a harmless sliver.
constexpr double kFoldAngle = 3.14159265358979323846;

struct Patch {
  uint32_t owner = 0;                       ///< the net whose winding the patch has
  uint32_t partner = kNotSelected;          ///< the selected net on the other side, if any
  uint32_t other = 0;                       ///< the region on the owner's other side (dense id)
  std::vector<uint32_t> owner_triangles;    ///< triangle numbers in the owner's mesh
  std::vector<uint32_t> partner_triangles;  ///< the same triangles in the partner's mesh
  /// Per patch triangle: kept as extracted (round a place where simplifying failed a check).
  std::vector<char> frozen;
  int rounds = 0;  ///< freezing rounds so far
  bool simplified = false;
  bool given_up = false;
  std::vector<uint32_t> owner_indices, partner_indices;  ///< when simplified: 3 a triangle
};

/// A net's triangles grouped by the region across them, by region id; triangle order kept.
std::vector<std::pair<uint32_t, std::vector<uint32_t>>> group_by_other(const LabelNet& net) {
  std::vector<uint32_t> order(net.other.size());
  for (uint32_t t = 0; t < order.size(); ++t) order[t] = t;
  std::stable_sort(order.begin(), order.end(),
                   [&](uint32_t a, uint32_t b) { return net.other[a] < net.other[b]; });
  std::vector<std::pair<uint32_t, std::vector<uint32_t>>> groups;
  for (uint32_t t : order) {
    if (groups.empty() || groups.back().first != net.other[t]) groups.push_back({net.other[t], {}});
    groups.back().second.push_back(t);
  }
  return groups;
}

/// Patches larger than this many triangles are cut into tiles (see split_into_tiles).
constexpr size_t kTileTriangles = 16384;

/// Cuts a large patch into tiles of at most kTileTriangles by halving it at the median of its
/// triangles' centroids along the longest side, again and again (a k-d tree). Each tile is a
/// patch: simplified on its own, in parallel with the others, its border with the next tile
/// locked like any patch border, and re-run on its own where a check fails, so the cost of a
/// failure stays local instead of re-running a whole skull. The seams keep their extracted
/// vertices, a few percent of a tile's.
void split_into_tiles(const LabelNet& owner, Patch patch, std::vector<Patch>& out) {
  const size_t n = patch.owner_triangles.size();
  if (n <= kTileTriangles) {
    patch.frozen.assign(n, 0);
    out.push_back(std::move(patch));
    return;
  }
  std::vector<Vec3> centroid(n);
  Vec3 lo{0, 0, 0}, hi{0, 0, 0};
  for (size_t k = 0; k < n; ++k) {
    const uint32_t* f = &owner.mesh.indices[3 * size_t(patch.owner_triangles[k])];
    const Vec3 &a = owner.mesh.positions[f[0]], &b = owner.mesh.positions[f[1]],
               &c = owner.mesh.positions[f[2]];
    centroid[k] = {(a.x + b.x + c.x) / 3, (a.y + b.y + c.y) / 3, (a.z + b.z + c.z) / 3};
    lo = k == 0 ? centroid[k] : Vec3{std::min(lo.x, centroid[k].x), std::min(lo.y, centroid[k].y),
                                     std::min(lo.z, centroid[k].z)};
    hi = k == 0 ? centroid[k] : Vec3{std::max(hi.x, centroid[k].x), std::max(hi.y, centroid[k].y),
                                     std::max(hi.z, centroid[k].z)};
  }
  const float extent[3] = {hi.x - lo.x, hi.y - lo.y, hi.z - lo.z};
  const int axis = extent[0] >= extent[1] && extent[0] >= extent[2] ? 0
                   : extent[1] >= extent[2]                         ? 1
                                                                    : 2;
  auto coordinate = [&](size_t k) { return (&centroid[k].x)[axis]; };
  std::vector<size_t> order(n);
  for (size_t k = 0; k < n; ++k) order[k] = k;
  std::nth_element(order.begin(), order.begin() + n / 2, order.end(), [&](size_t a, size_t b) {
    return coordinate(a) < coordinate(b) || (coordinate(a) == coordinate(b) && a < b);
  });
  for (int half = 0; half < 2; ++half) {
    std::vector<size_t> pick(order.begin() + (half ? n / 2 : 0),
                             half ? order.end() : order.begin() + n / 2);
    std::sort(pick.begin(), pick.end());  // the patch's triangle order, for determinism
    Patch tile;
    tile.owner = patch.owner;
    tile.partner = patch.partner;
    tile.other = patch.other;
    for (size_t k : pick) {
      tile.owner_triangles.push_back(patch.owner_triangles[k]);
      if (!patch.partner_triangles.empty()) {
        tile.partner_triangles.push_back(patch.partner_triangles[k]);
      }
    }
    split_into_tiles(owner, std::move(tile), out);
  }
}

std::vector<Patch> find_patches(const std::vector<LabelNet>& nets,
                                const std::vector<uint32_t>& output_of_id) {
  std::vector<std::vector<std::pair<uint32_t, std::vector<uint32_t>>>> groups(nets.size());
  tbb::parallel_for(size_t(0), nets.size(), [&](size_t o) { groups[o] = group_by_other(nets[o]); });
  std::vector<Patch> patches;
  for (uint32_t o = 0; o < nets.size(); ++o) {
    for (auto& [other, triangles] : groups[o]) {
      const uint32_t p = output_of_id[other];
      if (p != kNotSelected && p < o) continue;  // the partner owns it
      Patch patch;
      patch.owner = o;
      patch.other = other;
      patch.owner_triangles = std::move(triangles);
      if (p != kNotSelected) {
        patch.partner = p;
        auto& partner_groups = groups[p];
        auto it = std::lower_bound(partner_groups.begin(), partner_groups.end(), nets[o].id,
                                   [](const auto& g, uint32_t id) { return g.first < id; });
        if (it != partner_groups.end() && it->first == nets[o].id) {
          patch.partner_triangles = std::move(it->second);
        }
        // Extraction lists the shared triangles once for each side.
        assert(patch.partner_triangles.size() == patch.owner_triangles.size());
      }
      split_into_tiles(nets[o], std::move(patch), patches);
    }
  }
  return patches;
}

constexpr int kPartnerCorner[3] = {0, 2, 1};  // owner's corner c is the partner's corner

/// A patch as one mesh: its vertices are the sorted (owner vertex, partner vertex) pairs.
struct PatchMesh {
  std::vector<uint64_t> keys;
  std::vector<Vec3> positions;
  std::vector<unsigned int> indices;  ///< 3 a patch triangle, in the patch's order
};

PatchMesh patch_mesh(const std::vector<LabelNet>& nets,
                     const std::vector<std::vector<uint32_t>>& original, const Patch& patch) {
  const std::vector<uint32_t>& a = original[patch.owner];
  const std::vector<uint32_t>* b =
      patch.partner == kNotSelected ? nullptr : &original[patch.partner];
  const size_t n = patch.owner_triangles.size();
  std::vector<uint64_t> corner_keys(3 * n);
  for (size_t k = 0; k < n; ++k) {
    for (int c = 0; c < 3; ++c) {
      const uint64_t va = a[3 * size_t(patch.owner_triangles[k]) + c];
      const uint64_t vb =
          b == nullptr ? 0 : (*b)[3 * size_t(patch.partner_triangles[k]) + kPartnerCorner[c]];
      corner_keys[3 * k + c] = va << 32 | vb;
    }
  }
  PatchMesh m;
  m.keys = corner_keys;
  std::sort(m.keys.begin(), m.keys.end());
  m.keys.erase(std::unique(m.keys.begin(), m.keys.end()), m.keys.end());
  m.indices.resize(3 * n);
  for (size_t i = 0; i < 3 * n; ++i) {
    m.indices[i] =
        unsigned(std::lower_bound(m.keys.begin(), m.keys.end(), corner_keys[i]) - m.keys.begin());
  }
  const Mesh& mesh = nets[patch.owner].mesh;
  m.positions.resize(m.keys.size());
  for (size_t v = 0; v < m.keys.size(); ++v) m.positions[v] = mesh.positions[m.keys[v] >> 32];
  return m;
}

// ---- checks
// --------------------------------------------------------------------------------------

struct DirectedEdge {
  uint32_t from, to, corner;  // corner: where `from` is in the index list
};
bool operator<(const DirectedEdge& x, const DirectedEdge& y) {
  return x.from != y.from ? x.from < y.from : x.to != y.to ? x.to < y.to : x.corner < y.corner;
}

/// The half-edges of `count` indices, sorted.
std::vector<DirectedEdge> half_edges(const uint32_t* indices, size_t count) {
  std::vector<DirectedEdge> h(count / 3 * 3);
  for (size_t i = 0; i < h.size(); ++i) {
    const size_t t = i - i % 3;
    h[i] = {indices[i], indices[t + (i % 3 + 1) % 3], uint32_t(i)};
  }
  std::sort(h.begin(), h.end());
  return h;
}

/// The half-edge (from, to) in h[begin, end), or end.
size_t find_half_edge(const std::vector<DirectedEdge>& h, size_t begin, size_t end, uint32_t from,
                      uint32_t to) {
  auto it = std::lower_bound(h.begin() + begin, h.begin() + end, DirectedEdge{from, to, 0});
  return it != h.begin() + end && it->from == from && it->to == to ? size_t(it - h.begin()) : end;
}

/// Appends to `bad` the vertices where the triangles are not a manifold (oriented, every edge
/// used once each way, one fan a vertex), allowing a half-edge without its twin only where
/// `may_be_open(from, to)`. Returns whether none was found.
template <class MayBeOpen>
bool manifold_defects(const uint32_t* indices, size_t count, MayBeOpen&& may_be_open,
                      std::vector<uint32_t>* bad) {
  const std::vector<DirectedEdge> h = half_edges(indices, count);
  const size_t n = h.size();
  bool ok = true;
  auto fail = [&](uint32_t v) {
    ok = false;
    if (bad != nullptr) bad->push_back(v);
  };
  std::vector<char> open(n, 0);
  for (size_t i = 0; i < n; ++i) {
    const DirectedEdge& e = h[i];
    if (e.from == e.to) {
      fail(e.from);
    } else if (i + 1 < n && h[i + 1].from == e.from && h[i + 1].to == e.to) {
      fail(e.from), fail(e.to);
    } else if (find_half_edge(h, 0, n, e.to, e.from) == n) {
      open[i] = 1;
      if (!may_be_open(e.from, e.to)) fail(e.from), fail(e.to);
    }
  }
  if (!ok) return false;  // the fans below need the edges sound
  for (size_t begin = 0; begin < n;) {
    size_t end = begin;
    while (end < n && h[end].from == h[begin].from) ++end;
    const uint32_t v = h[begin].from;
    // A fan starts at an outgoing edge (v, x) with no triangle before it: (x, v) is open.
    size_t start = begin, starts = 0;
    for (size_t i = begin; i < end; ++i) {
      if (open[i] != 0) start = i, ++starts;
    }
    if (starts > 1) {
      fail(v);
    } else {
      // Round the vertex: from (v, x) in triangle (v, x, y) to the next outgoing edge, (v, y).
      size_t at = start, steps = 0;
      do {
        const size_t corner = h[at].corner, t = corner - corner % 3;
        at = find_half_edge(h, begin, end, v, indices[t + (corner % 3 + 2) % 3]);
        ++steps;
      } while (at != end && at != start && steps <= end - begin);
      if (steps != end - begin || (starts == 0 && at != start)) fail(v);
    }
    begin = end;
  }
  return ok;
}

/// Removes the pairs of triangles that meshopt_simplify folds back to back (the same three
/// vertices, opposite windings: a feature collapsed to zero volume, the commonest way it breaks
/// a manifold). Returns how many triangles went.
size_t remove_folds(std::vector<unsigned int>& indices) {
  const size_t n = indices.size() / 3;
  std::vector<std::array<unsigned, 4>> sorted(n);  // sorted corners, triangle
  for (size_t t = 0; t < n; ++t) {
    std::array<unsigned, 3> c = {indices[3 * t], indices[3 * t + 1], indices[3 * t + 2]};
    std::sort(c.begin(), c.end());
    sorted[t] = {c[0], c[1], c[2], unsigned(t)};
  }
  std::sort(sorted.begin(), sorted.end());
  // Rotated to start at its smallest corner, a triangle and its reverse differ in corner 1.
  auto second = [&](unsigned t) {
    const unsigned* f = &indices[3 * size_t(t)];
    const int first = f[0] < f[1] ? (f[0] < f[2] ? 0 : 2) : (f[1] < f[2] ? 1 : 2);
    return f[(first + 1) % 3];
  };
  std::vector<char> drop(n, 0);
  size_t dropped = 0;
  for (size_t i = 0; i + 1 < n; ++i) {
    const auto& a = sorted[i];
    const auto& b = sorted[i + 1];
    if (a[0] != b[0] || a[1] != b[1] || a[2] != b[2]) continue;
    if (drop[a[3]] != 0 || drop[b[3]] != 0 || second(a[3]) == second(b[3])) continue;
    drop[a[3]] = drop[b[3]] = 1;
    dropped += 2;
  }
  if (dropped == 0) return 0;
  size_t w = 0;
  for (size_t t = 0; t < n; ++t) {
    if (drop[t] != 0) continue;
    for (int c = 0; c < 3; ++c) indices[w++] = indices[3 * t + c];
  }
  indices.resize(w);
  return dropped;
}

/// Appends to `bad` the corners of every border half-edge (sorted from << 32 | to keys) that
/// `indices` no longer holds: the border is shared with the neighbouring patches.
void missing_border(const std::vector<uint64_t>& border, const std::vector<unsigned int>& indices,
                    std::vector<uint32_t>& bad) {
  std::vector<uint64_t> have;
  have.reserve(indices.size());
  for (size_t i = 0; i < indices.size(); ++i) {
    const size_t t = i - i % 3;
    have.push_back(uint64_t(indices[i]) << 32 | indices[t + (i % 3 + 1) % 3]);
  }
  std::sort(have.begin(), have.end());
  for (uint64_t e : border) {
    if (!std::binary_search(have.begin(), have.end(), e)) {
      bad.push_back(uint32_t(e >> 32));
      bad.push_back(uint32_t(e));
    }
  }
}

/// The angle at corner `c` of triangle `f`.
double corner_angle(const std::vector<Vec3>& positions, const unsigned int* f, int c) {
  const Vec3d p = to_double(positions[f[c]]);
  const Vec3d u = to_double(positions[f[(c + 1) % 3]]) - p;
  const Vec3d v = to_double(positions[f[(c + 2) % 3]]) - p;
  return std::atan2(length(cross(u, v)), dot(u, v));
}

/// Appends to `bad` the corners of simplified triangles that are degenerate (zero area) or that
/// fold onto a neighbouring patch. The second: a border vertex left with one triangle (an ear
/// over its two border edges) where the extracted patch turned round it by over half a turn
/// (its triangles' angles there add up to more than kFoldAngle): the ear then spans the
/// border's chord on the far side, over the neighbouring patch (as round the rim where two
/// boxes touch).
void shape_defects(const PatchMesh& m, const std::vector<unsigned int>& out,
                   std::vector<uint32_t>& bad) {
  std::vector<uint32_t> before(m.keys.size(), 0), after(m.keys.size(), 0);
  for (unsigned int v : m.indices) ++before[v];
  for (unsigned int v : out) ++after[v];
  std::vector<double> turn;  // the extracted angle sum, where needed
  for (size_t t = 0; t < out.size(); t += 3) {
    const unsigned int* f = &out[t];
    const Vec3d n = triangle_cross(m.positions[f[0]], m.positions[f[1]], m.positions[f[2]]);
    bool defect = n.x == 0 && n.y == 0 && n.z == 0;
    for (int c = 0; c < 3 && !defect; ++c) {
      if (after[f[c]] != 1 || before[f[c]] < 2) continue;
      if (turn.empty()) {
        turn.assign(m.keys.size(), 0);
        for (size_t u = 0; u < m.indices.size(); u += 3) {
          for (int k = 0; k < 3; ++k)
            turn[m.indices[u + k]] += corner_angle(m.positions, &m.indices[u], k);
        }
      }
      defect = turn[f[c]] > kFoldAngle;
    }
    if (defect) bad.insert(bad.end(), f, f + 3);
  }
}

/// Appends to `bad` the vertices of every closed piece of the patch (a whole component of the
/// surface, no border) whose enclosed volume changed sign or that vanished: meshopt_simplify can
/// turn a blob of a few voxels inside out, or drop it.
void volume_defects(const PatchMesh& m, const std::vector<uint64_t>& border,
                    const std::vector<unsigned int>& out, std::vector<uint32_t>& bad) {
  std::vector<uint32_t> parent(m.keys.size());
  for (uint32_t v = 0; v < parent.size(); ++v) parent[v] = v;
  auto find = [&](uint32_t v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (size_t i = 0; i < m.indices.size(); i += 3) {
    for (int c = 1; c < 3; ++c) {
      const uint32_t a = find(m.indices[i]), b = find(m.indices[i + c]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  }
  std::vector<char> open(m.keys.size(), 0);
  for (uint64_t e : border) open[find(uint32_t(e >> 32))] = 1;
  const Vec3d origin = to_double(m.positions[0]);
  auto volumes = [&](const std::vector<unsigned int>& indices) {
    std::vector<double> v(m.keys.size(), 0);
    for (size_t i = 0; i < indices.size(); i += 3) {
      const Vec3d a = to_double(m.positions[indices[i]]) - origin;
      const Vec3d b = to_double(m.positions[indices[i + 1]]) - origin;
      const Vec3d c = to_double(m.positions[indices[i + 2]]) - origin;
      v[find(indices[i])] += dot(a, cross(b, c)) / 6;
    }
    return v;
  };
  const std::vector<double> before = volumes(m.indices), after = volumes(out);
  for (unsigned int v : m.indices) {
    const uint32_t r = find(v);
    if (open[r] == 0 && (before[r] > 0) != (after[r] > 0)) bad.push_back(v);
  }
}

/// Per net, the vertices several of its patches share (the junction lines): (vertex, patch),
/// sorted, and beside each the patch's extracted normal there (its triangles' cross products
/// at the vertex, added up).
struct Junctions {
  std::vector<std::vector<std::pair<uint32_t, uint32_t>>> at;
  std::vector<std::vector<Vec3d>> normal;
};

Junctions find_junctions(const std::vector<LabelNet>& nets,
                         const std::vector<std::vector<uint32_t>>& original,
                         const std::vector<Patch>& patches,
                         const std::vector<std::vector<uint32_t>>& touching) {
  Junctions j;
  j.at.resize(nets.size());
  j.normal.resize(nets.size());
  tbb::parallel_for(size_t(0), nets.size(), [&](size_t o) {
    struct Corner {
      uint32_t vertex, patch;
      Vec3d normal;
    };
    std::vector<Corner> all;
    const std::vector<Vec3>& positions = nets[o].mesh.positions;
    for (uint32_t p : touching[o]) {
      const Patch& patch = patches[p];
      for (uint32_t t : patch.owner == o ? patch.owner_triangles : patch.partner_triangles) {
        const uint32_t* f = &original[o][3 * size_t(t)];
        const Vec3d n = triangle_cross(positions[f[0]], positions[f[1]], positions[f[2]]);
        for (int c = 0; c < 3; ++c) all.push_back({f[c], p, n});
      }
    }
    std::stable_sort(all.begin(), all.end(), [](const Corner& x, const Corner& y) {
      return x.vertex != y.vertex ? x.vertex < y.vertex : x.patch < y.patch;
    });
    for (size_t i = 0; i < all.size();) {
      size_t k = i;
      while (k < all.size() && all[k].vertex == all[i].vertex) ++k;
      if (all[k - 1].patch != all[i].patch) {  // two patches or more
        for (size_t r = i; r < k; ++r) {
          if (r > i && all[r].patch == all[r - 1].patch) {
            j.normal[o].back() = j.normal[o].back() + all[r].normal;
          } else {
            j.at[o].push_back({all[r].vertex, all[r].patch});
            j.normal[o].push_back(all[r].normal);
          }
        }
      }
      i = k;
    }
  });
  return j;
}

/// The entry of (vertex, patch) in at[net], or at[net].size().
size_t junction(const Junctions& j, size_t net, uint32_t vertex, uint32_t patch) {
  const auto& at = j.at[net];
  auto it = std::lower_bound(at.begin(), at.end(), std::pair<uint32_t, uint32_t>{vertex, patch});
  return it != at.end() && it->first == vertex && it->second == patch ? size_t(it - at.begin())
                                                                      : at.size();
}

/// A patch other than `self` that holds the net vertices `v` (all three, or the first two when
/// v[2] is UINT32_MAX), with `below` one numbered below `self`; UINT32_MAX if none.
uint32_t other_patch_holding(const Junctions& j, size_t net, const uint32_t (&v)[3], uint32_t self,
                             bool below) {
  const auto& at = j.at[net];
  auto it = std::lower_bound(at.begin(), at.end(), std::pair<uint32_t, uint32_t>{v[0], 0});
  for (; it != at.end() && it->first == v[0]; ++it) {
    const uint32_t q = it->second;
    if (q == self || (below && q > self)) continue;
    if (junction(j, net, v[1], q) == at.size()) continue;
    if (v[2] != UINT32_MAX && junction(j, net, v[2], q) == at.size()) continue;
    return q;
  }
  return UINT32_MAX;
}

/// Appends to `bad` the corners of what the simplified patch adds along a border it shares with
/// another patch Q:
///   - a new edge between two vertices of a border shared with a lower-numbered Q: two patches
///     meeting along a junction line may each span the same chord of it, and the assembled mesh
///     would hold that edge four times; of the patches along a junction line, only the lowest
///     may add chords;
///   - a new triangle whose three corners lie on the border with Q and that lies more in Q's
///     surface there than in this patch's (its normal nearer Q's normal, either way round, than
///     this patch's), or faces away from this patch's: where the junction line curves away from
///     the patch, the chord triangle lies on Q, a fold (as round the rim where two boxes touch).
void border_defects(const PatchMesh& m, const Patch& patch, uint32_t self, const Junctions& j,
                    const std::vector<uint64_t>& border, const std::vector<unsigned int>& out,
                    std::vector<uint32_t>& bad) {
  std::vector<char> on_border(m.keys.size(), 0);
  for (uint64_t e : border) on_border[e >> 32] = on_border[uint32_t(e)] = 1;
  auto key = [](uint32_t a, uint32_t b) {
    return a < b ? uint64_t(a) << 32 | b : uint64_t(b) << 32 | a;
  };
  std::vector<uint64_t> edges;
  std::vector<std::array<uint32_t, 3>> triangles;
  edges.reserve(m.indices.size());
  for (size_t i = 0; i < m.indices.size(); ++i) {
    edges.push_back(key(m.indices[i], m.indices[i - i % 3 + (i % 3 + 1) % 3]));
    if (i % 3 == 0) {
      std::array<uint32_t, 3> t = {m.indices[i], m.indices[i + 1], m.indices[i + 2]};
      std::sort(t.begin(), t.end());
      triangles.push_back(t);
    }
  }
  std::sort(edges.begin(), edges.end());
  std::sort(triangles.begin(), triangles.end());
  // The sides: the owner's net (patch vertex key >> 32, the patch's winding) and the partner's
  // (the key's low half, the opposite winding).
  const int sides = patch.partner == kNotSelected ? 1 : 2;
  auto net_vertex = [&](int side, uint32_t v) {
    return side == 0 ? uint32_t(m.keys[v] >> 32) : uint32_t(m.keys[v]);
  };
  for (size_t t = 0; t < out.size(); t += 3) {
    const uint32_t* f = &out[t];
    for (int c = 0; c < 3; ++c) {
      const uint32_t a = f[c], b = f[(c + 1) % 3];
      if (on_border[a] == 0 || on_border[b] == 0) continue;
      if (std::binary_search(edges.begin(), edges.end(), key(a, b))) continue;
      for (int side = 0; side < sides; ++side) {
        const size_t net = side == 0 ? patch.owner : patch.partner;
        const uint32_t v[3] = {net_vertex(side, a), net_vertex(side, b), UINT32_MAX};
        if (other_patch_holding(j, net, v, self, true) != UINT32_MAX) {
          bad.push_back(a), bad.push_back(b);
          break;
        }
      }
    }
    if (on_border[f[0]] == 0 || on_border[f[1]] == 0 || on_border[f[2]] == 0) continue;
    std::array<uint32_t, 3> sorted = {f[0], f[1], f[2]};
    std::sort(sorted.begin(), sorted.end());
    if (std::binary_search(triangles.begin(), triangles.end(), sorted)) continue;
    const Vec3d n = triangle_cross(m.positions[f[0]], m.positions[f[1]], m.positions[f[2]]);
    for (int side = 0; side < sides; ++side) {
      const size_t net = side == 0 ? patch.owner : patch.partner;
      const uint32_t v[3] = {net_vertex(side, f[0]), net_vertex(side, f[1]),
                             net_vertex(side, f[2])};
      const uint32_t q = other_patch_holding(j, net, v, self, false);
      if (q == UINT32_MAX) continue;
      Vec3d mine, theirs;
      for (uint32_t w : v) {
        mine = mine + j.normal[net][junction(j, net, w, self)];
        theirs = theirs + j.normal[net][junction(j, net, w, q)];
      }
      const Vec3d facing = side == 0 ? n : -1.0 * n;
      if (squared_length(mine) > 0 && squared_length(theirs) > 0 &&
          (dot(facing, mine) < 0 ||
           std::abs(dot(facing, normalize(theirs))) > dot(facing, normalize(mine)))) {
        bad.insert(bad.end(), f, f + 3);
        break;
      }
    }
  }
}

/// Barycentric sample points on a simplified triangle (its corners are extracted vertices):
/// the centroid, the edge midpoints and the points half-way from the centroid to each corner.
constexpr double kSamples[7][3] = {{1 / 3.0, 1 / 3.0, 1 / 3.0},
                                   {0.5, 0.5, 0},
                                   {0, 0.5, 0.5},
                                   {0.5, 0, 0.5},
                                   {2 / 3.0, 1 / 6.0, 1 / 6.0},
                                   {1 / 6.0, 2 / 3.0, 1 / 6.0},
                                   {1 / 6.0, 1 / 6.0, 2 / 3.0}};

Mesh triangles_of(const std::vector<Vec3>& positions, const unsigned int* indices, size_t count) {
  Mesh mesh;
  mesh.positions = positions;
  mesh.indices.assign(indices, indices + count);
  return mesh;
}

/// Whether `p` is within `precision` of the triangles `indices` (queried through `query`),
/// trying triangle `hint` first (the last one near enough: neighbouring points share it), and
/// updating it.
bool near_enough(const Vec3d& p, const std::vector<Vec3>& positions, const unsigned int* indices,
                 const DistanceQuery& query, double precision, uint32_t& hint) {
  if (hint != ClosestPoint::kNoTriangle) {
    const unsigned int* f = indices + 3 * size_t(hint);
    const ClosestPoint c = closest_point_on_triangle(
        p, to_double(positions[f[0]]), to_double(positions[f[1]]), to_double(positions[f[2]]));
    if (c.distance <= precision) return true;
  }
  const ClosestPoint c = query.closest(p, hint);
  hint = c.triangle;
  return c.distance <= precision;
}

/// Appends to `bad` the vertices where the simplified triangles `after` and the extracted
/// `before` are over `precision` apart: every vertex of `before` measured to `after`, and the
/// corners of every triangle of `after` with a kSamples point over `precision` from the
/// extracted patch (`extracted`, built on `extracted_indices`). A sampled check, like
/// hausdorff().
void distance_defects(const std::vector<Vec3>& positions, const unsigned int* before,
                      size_t before_count, const DistanceQuery& extracted,
                      const unsigned int* extracted_indices, const unsigned int* after,
                      size_t after_count, double precision, std::vector<uint32_t>& bad) {
  auto simplified = DistanceQuery::build(triangles_of(positions, after, after_count));
  if (!simplified.ok()) return;
  std::vector<char> seen(positions.size(), 0);
  uint32_t hint = ClosestPoint::kNoTriangle;
  for (size_t i = 0; i < before_count; ++i) {
    const unsigned v = before[i];
    if (seen[v] != 0) continue;
    seen[v] = 1;
    if (!near_enough(to_double(positions[v]), positions, after, *simplified, precision, hint)) {
      bad.push_back(v);
    }
  }
  hint = ClosestPoint::kNoTriangle;
  for (size_t t = 0; t < after_count; t += 3) {
    const Vec3d p[3] = {to_double(positions[after[t]]), to_double(positions[after[t + 1]]),
                        to_double(positions[after[t + 2]])};
    for (const auto& w : kSamples) {
      const Vec3d q = w[0] * p[0] + w[1] * p[1] + w[2] * p[2];
      if (!near_enough(q, positions, extracted_indices, extracted, precision, hint)) {
        bad.insert(bad.end(), after + t, after + t + 3);
        break;
      }
    }
  }
}

// ---- simplifying a patch
// -------------------------------------------------------------------------

/// Freezes the patch's triangles within `rings` triangle rings of the patch vertices `bad`.
void freeze_around(const PatchMesh& m, std::vector<char>& frozen, std::vector<uint32_t> bad,
                   int rings) {
  std::vector<std::pair<uint32_t, uint32_t>> round;  // (vertex, triangle), sorted
  round.reserve(m.indices.size());
  for (uint32_t i = 0; i < m.indices.size(); ++i) round.push_back({m.indices[i], i / 3});
  std::sort(round.begin(), round.end());
  std::sort(bad.begin(), bad.end());
  bad.erase(std::unique(bad.begin(), bad.end()), bad.end());
  std::vector<char> reached(frozen.size(), 0);
  std::vector<uint32_t> front = std::move(bad), next;
  for (int ring = 0; ring < rings && !front.empty(); ++ring) {
    next.clear();
    for (uint32_t v : front) {
      auto it = std::lower_bound(round.begin(), round.end(), std::pair<uint32_t, uint32_t>{v, 0});
      for (; it != round.end() && it->first == v; ++it) {
        if (reached[it->second] != 0) continue;
        reached[it->second] = 1;
        frozen[it->second] = 1;
        next.insert(next.end(), &m.indices[3 * size_t(it->second)],
                    &m.indices[3 * size_t(it->second)] + 3);
      }
    }
    std::sort(next.begin(), next.end());
    next.erase(std::unique(next.begin(), next.end()), next.end());
    std::swap(front, next);
  }
}

/// Simplifies one patch from its extracted triangles, first freezing round the patch vertices
/// `seeds` (places where an earlier result broke an assembled mesh), then freezing wherever the
/// result fails a check, until it passes; sets patch.simplified when the result differs from
/// the extraction, patch.given_up when it had to stay (or would vanish).
void simplify_patch(const std::vector<LabelNet>& nets,
                    const std::vector<std::vector<uint32_t>>& original, const Junctions& junctions,
                    uint32_t self, Patch& patch, double precision, std::vector<uint32_t> seeds) {
  patch.simplified = false;
  patch.owner_indices.clear();
  patch.partner_indices.clear();
  const size_t n = patch.owner_triangles.size();
  if (n == 0 || patch.given_up) return;
  const PatchMesh m = patch_mesh(nets, original, patch);
  if (!seeds.empty()) freeze_around(m, patch.frozen, std::move(seeds), 1 << patch.rounds);
  // The patch's own border: the extracted half-edges without a twin.
  std::vector<uint64_t> border;
  for (const DirectedEdge& e : half_edges(m.indices.data(), m.indices.size())) {
    border.push_back(uint64_t(e.from) << 32 | e.to);
  }
  std::vector<uint64_t> twins(border.size());
  for (size_t i = 0; i < border.size(); ++i) twins[i] = border[i] << 32 | border[i] >> 32;
  std::sort(twins.begin(), twins.end());
  border.erase(
      std::remove_if(border.begin(), border.end(),
                     [&](uint64_t e) { return std::binary_search(twins.begin(), twins.end(), e); }),
      border.end());
  auto may_be_open = [&](uint32_t from, uint32_t to) {
    return std::binary_search(border.begin(), border.end(), uint64_t(from) << 32 | to);
  };

  // Vertices where the extracted patch itself is no manifold with a border (it touches itself
  // there: one sheet of a label whose quads alternate between two regions round the vertex):
  // the check below cannot hold them to it; the assembled meshes' check still does.
  std::vector<char> pinched(m.keys.size(), 0);
  {
    std::vector<uint32_t> at;
    manifold_defects(m.indices.data(), m.indices.size(), may_be_open, &at);
    for (uint32_t v : at) pinched[v] = 1;
  }
  const float scale = meshopt_simplifyScale(&m.positions[0].x, m.positions.size(), sizeof(Vec3));
  if (!(scale > 0)) return;
  std::optional<DistanceQuery> extracted;
  std::vector<unsigned int> input, out;
  for (;; ++patch.rounds) {
    // Free triangles first: meshopt sees those; where they meet the frozen ones is a border.
    input.clear();
    for (int frozen = 0; frozen < 2; ++frozen) {
      for (size_t k = 0; k < n; ++k) {
        if ((patch.frozen[k] != 0) == (frozen != 0)) {
          input.insert(input.end(), &m.indices[3 * k], &m.indices[3 * k] + 3);
        }
      }
    }
    size_t free = 0;
    for (char f : patch.frozen) free += f == 0;
    if (free == 0) return;
    out.resize(3 * n);
    size_t kept = meshopt_simplify(
        out.data(), input.data(), 3 * free, &m.positions[0].x, m.positions.size(), sizeof(Vec3), 0,
        float(kErrorFactor * precision / scale), meshopt_SimplifyLockBorder, nullptr);
    if (kept == 0) {  // it would vanish
      patch.given_up = true;
      return;
    }
    if (kept == 3 * free) return;  // nothing to simplify
    out.resize(kept);
    remove_folds(out);
    kept = out.size();
    if (kept == 0) {
      patch.given_up = true;
      return;
    }
    out.insert(out.end(), input.begin() + 3 * free, input.end());

    std::vector<uint32_t> bad;
    manifold_defects(out.data(), out.size(), may_be_open, &bad);
    bad.erase(std::remove_if(bad.begin(), bad.end(), [&](uint32_t v) { return pinched[v] != 0; }),
              bad.end());
    missing_border(border, out, bad);
    shape_defects(m, out, bad);
    border_defects(m, patch, self, junctions, border, out, bad);
    volume_defects(m, border, out, bad);
    if (bad.empty()) {
      if (!extracted) {
        auto built = DistanceQuery::build(triangles_of(m.positions, m.indices.data(), 3 * n));
        if (!built.ok()) return;  // cannot measure: keep it as extracted
        extracted.emplace(std::move(built).value());
      }
      distance_defects(m.positions, input.data(), 3 * free, *extracted, m.indices.data(),
                       out.data(), kept, precision, bad);
    }
    if (bad.empty()) break;
    if (patch.rounds >= kFreezeRounds) {
      patch.given_up = true;
      return;
    }
    freeze_around(m, patch.frozen, std::move(bad), 1 << patch.rounds);
  }
  const bool two_sided = patch.partner != kNotSelected;
  patch.owner_indices.resize(out.size());
  if (two_sided) patch.partner_indices.resize(out.size());
  for (size_t t = 0; t < out.size(); t += 3) {
    for (int c = 0; c < 3; ++c) {
      const uint64_t key = m.keys[out[t + c]];
      patch.owner_indices[t + c] = uint32_t(key >> 32);
      if (two_sided) patch.partner_indices[t + kPartnerCorner[c]] = uint32_t(key);
    }
  }
  patch.simplified = true;
}

/// The patch vertices standing for vertices `bad` of net `self` (one side of the patch).
std::vector<uint32_t> patch_vertices(const std::vector<LabelNet>& nets,
                                     const std::vector<std::vector<uint32_t>>& original,
                                     const Patch& patch, uint32_t self,
                                     const std::vector<uint32_t>& bad) {
  const PatchMesh m = patch_mesh(nets, original, patch);
  const bool owner = patch.owner == self;
  std::vector<uint32_t> out;
  for (uint32_t v = 0; v < m.keys.size(); ++v) {
    const uint32_t id = owner ? uint32_t(m.keys[v] >> 32) : uint32_t(m.keys[v]);
    if (std::binary_search(bad.begin(), bad.end(), id)) out.push_back(v);
  }
  return out;
}

/// A net's triangles from its patches (simplified where they are), and each triangle's patch.
void assemble(const std::vector<uint32_t>& original, uint32_t self,
              const std::vector<Patch>& patches, const std::vector<uint32_t>& touching,
              std::vector<uint32_t>& indices, std::vector<uint32_t>& triangle_patch) {
  indices.clear();
  triangle_patch.clear();
  for (uint32_t p : touching) {
    const Patch& patch = patches[p];
    const bool owner = patch.owner == self;
    if (patch.simplified) {
      const std::vector<uint32_t>& src = owner ? patch.owner_indices : patch.partner_indices;
      indices.insert(indices.end(), src.begin(), src.end());
      triangle_patch.insert(triangle_patch.end(), src.size() / 3, p);
    } else {
      for (uint32_t t : owner ? patch.owner_triangles : patch.partner_triangles) {
        indices.insert(indices.end(), original.begin() + 3 * size_t(t),
                       original.begin() + 3 * size_t(t) + 3);
        triangle_patch.push_back(p);
      }
    }
  }
}

}  // namespace

bool is_closed_manifold(const std::vector<uint32_t>& indices, std::vector<uint32_t>* bad) {
  return manifold_defects(
      indices.data(), indices.size(), [](uint32_t, uint32_t) { return false; }, bad);
}

SimplifyReport simplify_nets(std::vector<LabelNet>& nets, const std::vector<uint32_t>& output_of_id,
                             double precision) {
  SimplifyReport report;
  std::vector<Patch> patches = find_patches(nets, output_of_id);
  report.patches = patches.size();
  std::vector<std::vector<uint32_t>> original(nets.size());
  for (size_t o = 0; o < nets.size(); ++o) original[o] = std::move(nets[o].mesh.indices);
  // Which patches each net is made of, in patch order.
  std::vector<std::vector<uint32_t>> touching(nets.size());
  for (uint32_t p = 0; p < patches.size(); ++p) {
    touching[patches[p].owner].push_back(p);
    if (patches[p].partner != kNotSelected) touching[patches[p].partner].push_back(p);
  }

  const Junctions junctions = find_junctions(nets, original, patches, touching);

  // Simplify every patch, assemble the meshes and check each is a closed manifold; a patch that
  // passed its own checks can still break one with a neighbour (an edge both create between two
  // border vertices): those are simplified again, frozen round the place. The extracted nets
  // are closed manifolds, so this ends.
  std::vector<std::vector<uint32_t>> seeds(patches.size());
  std::vector<char> redo(patches.size(), 1);
  std::vector<std::vector<uint32_t>> triangle_patch(nets.size());
  for (;;) {
    tbb::parallel_for(
        tbb::blocked_range<size_t>(0, patches.size(), 1),
        [&](const tbb::blocked_range<size_t>& range) {
          for (size_t p = range.begin(); p < range.end(); ++p) {
            if (redo[p] != 0) {
              simplify_patch(nets, original, junctions, uint32_t(p), patches[p], precision,
                             std::move(seeds[p]));
            }
          }
        },
        tbb::simple_partitioner());
    // bad[o]: (patch, vertex of net o) where net o is not a closed manifold.
    std::vector<std::vector<std::pair<uint32_t, uint32_t>>> bad(nets.size());
    tbb::parallel_for(size_t(0), nets.size(), [&](size_t o) {
      Mesh& mesh = nets[o].mesh;
      assemble(original[o], uint32_t(o), patches, touching[o], mesh.indices, triangle_patch[o]);
      std::vector<uint32_t> vertices;
      if (is_closed_manifold(mesh.indices, &vertices)) return;
      std::vector<char> is_bad(mesh.positions.size(), 0);
      for (uint32_t v : vertices) is_bad[v] = 1;
      for (size_t t = 0; t < triangle_patch[o].size(); ++t) {
        const uint32_t p = triangle_patch[o][t];
        if (!patches[p].simplified) continue;
        for (int c = 0; c < 3; ++c) {
          const uint32_t v = mesh.indices[3 * t + c];
          if (is_bad[v] != 0) bad[o].push_back({p, v});
        }
      }
    });
    std::fill(redo.begin(), redo.end(), 0);
    bool any = false;
    for (uint32_t o = 0; o < nets.size(); ++o) {
      std::sort(bad[o].begin(), bad[o].end());
      for (size_t i = 0; i < bad[o].size();) {
        const uint32_t p = bad[o][i].first;
        std::vector<uint32_t> vertices;
        for (; i < bad[o].size() && bad[o][i].first == p; ++i) vertices.push_back(bad[o][i].second);
        Patch& patch = patches[p];
        any = true;
        redo[p] = 1;
        if (++patch.rounds > kFreezeRounds) {
          patch.given_up = true;
          continue;
        }
        std::vector<uint32_t> v = patch_vertices(nets, original, patch, o, vertices);
        seeds[p].insert(seeds[p].end(), v.begin(), v.end());
      }
    }
    if (!any) break;
  }
  for (const Patch& patch : patches) {
    report.unsimplified += patch.given_up;
    report.frozen_patches += !patch.given_up && patch.rounds > 0;
  }
  for (uint32_t o = 0; o < nets.size(); ++o) {
    LabelNet& net = nets[o];
    remove_unreferenced_vertices(net.mesh);
    net.other.resize(triangle_patch[o].size());
    for (size_t t = 0; t < net.other.size(); ++t) {
      const Patch& patch = patches[triangle_patch[o][t]];
      net.other[t] = patch.owner == o ? patch.other : nets[patch.owner].id;
    }
  }
  return report;
}

}  // namespace osteon::detail
