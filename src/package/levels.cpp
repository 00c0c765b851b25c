// SPDX-License-Identifier: Apache-2.0
#include <meshoptimizer.h>

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "osteon/hausdorff.hpp"
#include "osteon/mesh.hpp"
#include "osteon/repeats.hpp"
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

namespace {

/// The vertices that `indices` (triangles of `mesh`) use, in order of first use.
struct Compacted {
  std::vector<Vec3> positions;
  std::vector<uint32_t> source;   ///< each vertex's id in `mesh`
  std::vector<uint32_t> indices;  ///< `indices`, renumbered to them
};

/// `remap` holds UINT32_MAX for every vertex of `mesh` and is left so (only the entries of the
/// vertices used are touched), so that many small calls cost their own size, not the mesh's.
Compacted compact(const Mesh& mesh, const std::vector<uint32_t>& indices,
                  std::vector<uint32_t>& remap) {
  Compacted out;
  out.indices.reserve(indices.size());
  for (uint32_t v : indices) {
    if (remap[v] == UINT32_MAX) {
      remap[v] = static_cast<uint32_t>(out.positions.size());
      out.positions.push_back(mesh.positions[v]);
      out.source.push_back(v);
    }
    out.indices.push_back(remap[v]);
  }
  for (uint32_t v : out.source) remap[v] = UINT32_MAX;
  return out;
}

}  // namespace

Mesh submesh(const Mesh& mesh, const std::vector<uint32_t>& indices) {
  Mesh out;
  out.name = mesh.name;
  out.source = mesh.source;
  out.unit = mesh.unit;
  out.unit_source = mesh.unit_source;
  std::vector<uint32_t> remap(mesh.positions.size(), UINT32_MAX);
  Compacted used = compact(mesh, indices, remap);
  out.positions = std::move(used.positions);
  out.indices = std::move(used.indices);
  out.stored_vertices = out.positions.size();
  return out;
}

namespace {

/// Connected pieces (triangles sharing a vertex) smaller than this stay whole at every level:
/// meshopt collapses a small closed island to nothing, and a fragment of a label 200 mm from the
/// rest of its bone, dropped, is a level 200 mm off.
constexpr uint64_t kKeptIsland = 64;
/// The largest error meshopt may spend on a level, as a share of the piece's extent: without a
/// limit a long thin bone is crushed to reach a quarter (a clavicle piece went from 0.8 to 76 mm
/// between two levels); with it the chain ends where the next quarter would cost more.
constexpr float kLevelErrorShare = 0.05f;

/// meshopt_simplify on the triangles `indices` of `mesh` alone, to about `target` triangles
/// within `error` (absolute), border locked; appends the result, in mesh's vertex ids. `remap`
/// as compact() takes it.
void simplify_into(const Mesh& mesh, const std::vector<uint32_t>& indices, uint64_t target,
                   float error, std::vector<uint32_t>& remap, std::vector<uint32_t>* out) {
  const Compacted island = compact(mesh, indices, remap);
  const std::vector<Vec3>& positions = island.positions;
  const float scale = meshopt_simplifyScale(&positions[0].x, positions.size(), sizeof(Vec3));
  std::vector<uint32_t> kept(island.indices.size());
  const size_t count = meshopt_simplify(
      kept.data(), island.indices.data(), island.indices.size(), &positions[0].x,
      positions.size(), sizeof(Vec3), size_t(3 * target), scale > 0 ? error / scale : 0.0f,
      meshopt_SimplifyLockBorder, nullptr);
  for (size_t i = 0; i < count; ++i) out->push_back(island.source[kept[i]]);
}

/// One step of the chain: `finer`'s triangles simplified to about `target` in all, each
/// connected island on its own with its share of the target (so none vanishes), islands under
/// kKeptIsland triangles kept as they are. Returns the kept triangles, in finer's vertex ids.
std::vector<uint32_t> simplify_step(const Mesh& finer, uint64_t target, float error) {
  const uint64_t triangles = finer.triangle_count();
  // Islands numbered in the order of their first triangle, so the output is deterministic.
  uint32_t count = 0;
  const std::vector<uint32_t> piece = connected_pieces(finer, &count);
  std::vector<std::vector<uint32_t>> islands(count);
  for (size_t t = 0; t < triangles; ++t) {
    const auto first = finer.indices.begin() + 3 * t;
    islands[piece[t]].insert(islands[piece[t]].end(), first, first + 3);
  }
  std::vector<uint32_t> kept;
  kept.reserve(3 * target);
  std::vector<uint32_t> remap(finer.positions.size(), UINT32_MAX);
  for (const std::vector<uint32_t>& island : islands) {
    const uint64_t n = island.size() / 3;
    if (n < kKeptIsland) {
      kept.insert(kept.end(), island.begin(), island.end());
      continue;
    }
    const uint64_t share = std::max<uint64_t>(kKeptIsland / 2, n * target / triangles);
    simplify_into(finer, island, share, error, remap, &kept);
  }
  return kept;
}

}  // namespace

std::vector<Mesh> detail_levels(const Mesh& full, int max_levels) {
  std::vector<Mesh> levels;  // finest first while building
  // Each level is simplified from the one before it, held in `levels`: no reallocation may move
  // it (a chain of quarters from 2^32 triangles has 16 levels).
  levels.reserve(32);
  if (full.positions.empty()) return levels;
  const Mesh* finer = &full;
  const float error =
      kLevelErrorShare * meshopt_simplifyScale(&full.positions[0].x, full.positions.size(),
                                               sizeof(Vec3));
  while (max_levels == 0 || static_cast<int>(levels.size()) + 1 < max_levels) {
    const uint64_t triangles = finer->triangle_count();
    const uint64_t target = triangles / 4;
    if (target < kMinLevelTriangles) break;
    const std::vector<uint32_t> kept = simplify_step(*finer, target, error);
    const uint64_t count = kept.size() / 3;
    if (count == 0 || 4 * count > 3 * triangles) break;  // the border or the error holds it up
    levels.push_back(submesh(*finer, kept));
    finer = &levels.back();
  }
  std::reverse(levels.begin(), levels.end());
  return levels;
}

Result<double> level_distance(const Mesh& full, const DistanceQuery& to_full, const Mesh& level,
                              LevelSampling sampling) {
  // Both ways: from the level's vertices, edges and faces to the full surface (a level's
  // triangles are large, and its largest distance is often inside one); and from the vertices of
  // the full level to the level's surface, where a simplification's error peaks (the vertices it
  // removed, and whole islands: meshopt may collapse a small closed component of a bone to
  // nothing, and a subset of the full vertices can miss it, which once recorded 3 mm for a level
  // 120 mm off). Only the largest distance is wanted, so a sample stops at the first triangle
  // that cannot raise it (HausdorffOptions::max_only): every full vertex costs little more than
  // its hint.
  const bool estimate = sampling == LevelSampling::kEstimate;
  HausdorffOptions level_samples;
  level_samples.samples_per_face = estimate ? 3 : 30;
  level_samples.max_only = true;  // the level's error is the largest distance alone
  OSTEON_ASSIGN_OR_RETURN(OneSidedDistance forward,
                          one_sided_distance(level, to_full, level_samples));
  OSTEON_ASSIGN_OR_RETURN(DistanceQuery to_level, DistanceQuery::build(level));
  HausdorffOptions full_vertices;
  full_vertices.max_only = true;
  full_vertices.samples = estimate ? (full.positions.size() + 3) / 4 : full.positions.size();
  full_vertices.sample_edges = false;
  full_vertices.sample_faces = false;
  full_vertices.known_max = forward.max;  // only the larger of the two is kept
  OSTEON_ASSIGN_OR_RETURN(OneSidedDistance backward,
                          one_sided_distance(full, to_level, full_vertices));
  return std::max(forward.max, backward.max);
}

}  // namespace osteon::detail
