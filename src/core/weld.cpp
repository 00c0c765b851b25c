// SPDX-License-Identifier: Apache-2.0
#include "core/weld.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "osteon/mesh.hpp"

// Based on: hash-based vertex welding as in meshoptimizer's meshopt_generateVertexRemap (exact
// equality, open addressing) and uniform-grid clustering for the tolerance weld.

namespace osteon {
namespace detail {

namespace {
size_t table_size_for(size_t vertices) {
  size_t size = 64;
  while (size < vertices * 2) size *= 2;
  return size;
}
}  // namespace

ExactWelder::ExactWelder(std::vector<Vec3>* positions, size_t expected)
    : positions_(positions), table_(table_size_for(std::max(expected, positions->size())), kEmpty) {
  for (uint32_t id = 0; id < positions_->size(); ++id) {
    ExactWelder::canonicalize((*positions_)[id]);
  }
  // Re-insert existing positions (they are assumed distinct; weld() starts from an empty vector).
  uint64_t mask = table_.size() - 1;
  for (uint32_t id = 0; id < positions_->size(); ++id) {
    uint64_t slot = hash((*positions_)[id]) & mask;
    while (table_[slot] != kEmpty) slot = (slot + 1) & mask;
    table_[slot] = id;
  }
}

void ExactWelder::grow() {
  std::vector<uint32_t> old;
  old.swap(table_);
  table_.assign(old.size() * 2, kEmpty);
  uint64_t mask = table_.size() - 1;
  for (uint32_t id : old) {
    if (id == kEmpty) continue;
    uint64_t slot = hash((*positions_)[id]) & mask;
    while (table_[slot] != kEmpty) slot = (slot + 1) & mask;
    table_[slot] = id;
  }
}

}  // namespace detail

namespace {

// Exact weld: remap[i] is the first vertex with i's position. New ids are assigned in first-
// occurrence order, so the new id of i is <= i and the positions can be compacted in place.
std::vector<uint32_t> exact_remap(Mesh& mesh) {
  std::vector<Vec3> unique;
  unique.reserve(mesh.positions.size());
  detail::ExactWelder welder(&unique, mesh.positions.size());
  std::vector<uint32_t> remap(mesh.positions.size());
  for (size_t i = 0; i < mesh.positions.size(); ++i) remap[i] = welder.insert(mesh.positions[i]);
  mesh.positions.swap(unique);
  return remap;
}

// Tolerance weld: greedy clustering in a uniform grid of cell size `tolerance`: each vertex joins
// the first earlier representative within `tolerance` in its 27 neighbouring cells, or becomes a
// representative itself. Known approximation: greedy, so the result depends on vertex order and a
// chain of points each within tolerance of the next is not merged transitively.
std::vector<uint32_t> tolerance_remap(Mesh& mesh, float tolerance) {
  const double cell = tolerance;
  const double tol2 = double(tolerance) * tolerance;
  auto key = [](int64_t x, int64_t y, int64_t z) {
    return (uint64_t(x) * 73856093ull) ^ (uint64_t(y) * 19349663ull) ^ (uint64_t(z) * 83492791ull);
  };
  struct Cell {
    int64_t x, y, z;
  };
  // Cell coordinates are clamped so that huge coordinates over a tiny tolerance cannot overflow
  // the integer conversion; clamped cells are merely shared by far-apart points (distance decides).
  auto coord = [cell](float v) {
    double q = std::floor(double(v) / cell);
    return int64_t(std::clamp(q, -4.0e18, 4.0e18));
  };
  auto cell_of = [&](const Vec3& p) { return Cell{coord(p.x), coord(p.y), coord(p.z)}; };
  // cell key -> representatives (new ids) in that cell; collisions between cells are harmless
  // because candidates are checked by distance.
  std::unordered_map<uint64_t, std::vector<uint32_t>> grid;
  grid.reserve(mesh.positions.size());
  std::vector<Vec3> reps;
  std::vector<uint32_t> remap(mesh.positions.size());
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const Vec3& p = mesh.positions[i];
    Cell c = cell_of(p);
    uint32_t found = UINT32_MAX;
    for (int64_t dx = -1; dx <= 1 && found == UINT32_MAX; ++dx)
      for (int64_t dy = -1; dy <= 1 && found == UINT32_MAX; ++dy)
        for (int64_t dz = -1; dz <= 1 && found == UINT32_MAX; ++dz) {
          auto it = grid.find(key(c.x + dx, c.y + dy, c.z + dz));
          if (it == grid.end()) continue;
          for (uint32_t r : it->second) {
            double ex = double(reps[r].x) - p.x, ey = double(reps[r].y) - p.y,
                   ez = double(reps[r].z) - p.z;
            if (ex * ex + ey * ey + ez * ez <= tol2) {
              found = r;
              break;
            }
          }
        }
    if (found == UINT32_MAX) {
      found = static_cast<uint32_t>(reps.size());
      reps.push_back(p);
      grid[key(c.x, c.y, c.z)].push_back(found);
    }
    remap[i] = found;
  }
  mesh.positions.swap(reps);
  return remap;
}

}  // namespace

WeldReport weld(Mesh& mesh, const WeldOptions& options) {
  WeldReport report;
  report.vertices_before = mesh.positions.size();
  std::vector<Vec3> normals;
  normals.swap(mesh.normals);
  std::vector<uint32_t> remap =
      options.tolerance > 0 ? tolerance_remap(mesh, options.tolerance) : exact_remap(mesh);
  if (!normals.empty()) {
    // Each group keeps the normal of its first vertex: walk backwards so the first one wins.
    mesh.normals.assign(mesh.positions.size(), Vec3{});
    for (size_t i = remap.size(); i-- > 0;) mesh.normals[remap[i]] = normals[i];
  }
  for (uint32_t& index : mesh.indices) index = remap[index];
  report.vertices_after = mesh.positions.size();
  return report;
}

size_t remove_unreferenced_vertices(Mesh& mesh) {
  std::vector<uint32_t> remap(mesh.positions.size(), UINT32_MAX);
  for (uint32_t index : mesh.indices) remap[index] = 0;  // mark the referenced ones
  // Keep the original relative order of the vertices that stay.
  uint32_t next = 0;
  for (size_t i = 0; i < remap.size(); ++i) {
    if (remap[i] == UINT32_MAX) continue;
    remap[i] = next;
    mesh.positions[next] = mesh.positions[i];
    if (!mesh.normals.empty()) mesh.normals[next] = mesh.normals[i];
    ++next;
  }
  size_t removed = mesh.positions.size() - next;
  mesh.positions.resize(next);
  if (!mesh.normals.empty()) mesh.normals.resize(next);
  for (uint32_t& index : mesh.indices) index = remap[index];
  return removed;
}

bool is_degenerate_triangle(const Mesh& mesh, size_t t) {
  uint32_t a = mesh.indices[3 * t], b = mesh.indices[3 * t + 1], c = mesh.indices[3 * t + 2];
  if (a == b || b == c || a == c) return true;
  const Vec3 &p = mesh.positions[a], &q = mesh.positions[b], &r = mesh.positions[c];
  return triangle_cross(p, q, r) == Vec3d{0, 0, 0};
}

size_t count_degenerate_triangles(const Mesh& mesh) {
  size_t count = 0;
  for (size_t t = 0; t < mesh.triangle_count(); ++t) count += is_degenerate_triangle(mesh, t);
  return count;
}

size_t remove_degenerate_triangles(Mesh& mesh) {
  size_t kept = 0, n = mesh.triangle_count();
  for (size_t t = 0; t < n; ++t) {
    if (is_degenerate_triangle(mesh, t)) continue;
    for (int k = 0; k < 3; ++k) mesh.indices[3 * kept + k] = mesh.indices[3 * t + k];
    ++kept;
  }
  mesh.indices.resize(3 * kept);
  return n - kept;
}

}  // namespace osteon
