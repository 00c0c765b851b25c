// SPDX-License-Identifier: Apache-2.0
#include <meshoptimizer.h>

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "osteon/hausdorff.hpp"
#include "osteon/mesh.hpp"
#include "package/package_internal.hpp"

// Based on: M. Garland, P. Heckbert, "Surface simplification using quadric error metrics",
// SIGGRAPH 1997, as meshoptimizer's meshopt_simplify implements it (A. Kapoulkine), with
// meshopt_SimplifyLockBorder; the chain of levels each about a quarter of the next, as in
// Nexus (F. Ponchio, M. Dellepiane, "Multiresolution and fast decompression for optimal web-based
// rendering", Graphical Models 88, 2016) and 3D Tiles' geometric-error refinement.
//
// Why each level is simplified from the one above it rather than from the full mesh: the chain
// costs about 4/3 of one simplification of the full mesh instead of one per level, and the border
// is locked at every step, so every level keeps the full level's border vertices (meshopt only
// ever removes vertices) and the pieces of one bone meet without cracks at any mix of levels.
// The error is measured against the full level, not summed along the chain.

namespace osteon::detail {

Mesh submesh(const Mesh& mesh, const std::vector<uint32_t>& indices) {
  Mesh out;
  out.name = mesh.name;
  out.source = mesh.source;
  out.unit = mesh.unit;
  out.unit_source = mesh.unit_source;
  std::vector<uint32_t> remap(mesh.positions.size(), UINT32_MAX);
  out.indices.reserve(indices.size());
  for (uint32_t v : indices) {
    if (remap[v] == UINT32_MAX) {
      remap[v] = static_cast<uint32_t>(out.positions.size());
      out.positions.push_back(mesh.positions[v]);
    }
    out.indices.push_back(remap[v]);
  }
  out.stored_vertices = out.positions.size();
  return out;
}

Result<std::vector<DetailLevel>> detail_levels(const Mesh& full, int max_levels) {
  std::vector<DetailLevel> levels;  // finest first while building
  // Each level is simplified from the one before it, held in `levels`: no reallocation may move
  // it (a chain of quarters from 2^32 triangles has 16 levels).
  levels.reserve(32);
  const Mesh* finer = &full;
  std::vector<uint32_t> kept;
  while (max_levels == 0 || static_cast<int>(levels.size()) + 1 < max_levels) {
    const uint64_t triangles = finer->triangle_count();
    const uint64_t target = triangles / 4;
    if (target < kMinLevelTriangles) break;
    kept.resize(finer->indices.size());
    // The target count decides; the error limit (the whole mesh's extent) never stops it first.
    const size_t count = meshopt_simplify(
        kept.data(), finer->indices.data(), finer->indices.size(), &finer->positions[0].x,
        finer->positions.size(), sizeof(Vec3), size_t(3 * target), 1.0f,
        meshopt_SimplifyLockBorder, nullptr);
    if (count == 0 || 4 * (count / 3) > 3 * triangles) break;  // the border holds it up
    kept.resize(count);
    DetailLevel level;
    level.mesh = submesh(*finer, kept);
    levels.push_back(std::move(level));
    finer = &levels.back().mesh;
  }
  if (levels.empty()) return levels;
  // Both ways: from the level's vertices, edges and faces (3 samples a triangle) to the full
  // surface, whose hierarchy is built once for every level; and from the vertices of the full
  // level to the level's surface, where a simplification's error peaks (the vertices it removed).
  // Vertices alone on that side cost a sixth of Metro's 3-a-triangle samples, on the mesh that is
  // four times larger than the next level: the measurement was three fifths of the levels' time.
  // A level gets at most 8 full vertices per vertex of its own (stratified over the full
  // vertices: every one of them for the finest coarser level), far denser than its own error.
  OSTEON_ASSIGN_OR_RETURN(DistanceQuery to_full, DistanceQuery::build(full));
  HausdorffOptions level_samples;
  level_samples.samples_per_face = 3;
  level_samples.max_only = true;  // the level's error is the largest distance alone
  HausdorffOptions full_vertices;
  full_vertices.max_only = true;
  full_vertices.sample_edges = false;
  full_vertices.sample_faces = false;
  for (DetailLevel& level : levels) {
    full_vertices.samples = std::min<uint64_t>(full.positions.size(), 8 * level.mesh.positions.size());
    OSTEON_ASSIGN_OR_RETURN(OneSidedDistance forward,
                            one_sided_distance(level.mesh, to_full, level_samples));
    OSTEON_ASSIGN_OR_RETURN(DistanceQuery to_level, DistanceQuery::build(level.mesh));
    OSTEON_ASSIGN_OR_RETURN(OneSidedDistance backward,
                            one_sided_distance(full, to_level, full_vertices));
    level.distance = std::max(forward.max, backward.max);
  }
  std::reverse(levels.begin(), levels.end());
  return levels;
}

}  // namespace osteon::detail
