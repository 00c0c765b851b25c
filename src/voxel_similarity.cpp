// SPDX-License-Identifier: Apache-2.0
#include "repeats_internal.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <vector>

// Based on: Zhou, Jia & Su (2018), section IV.C step 2, eq. (3)-(4): both components voxelised at
// N = 4096 voxels, Phi = the share of voxels whose occupancy agrees, Phi > 0.9 for a candidate.
// The paper does not say how a voxel is filled; here a voxel is occupied when the surface passes
// through it (the BodyParts3D bones are mostly open surfaces, so "inside" is undefined), found
// by a barycentric grid of points on each triangle spaced at most a third of a voxel. Each
// component is voxelised over its own normalised AABB, 16 voxels a side, as the paper's step 1
// compares AABBs before voxelising: two components whose normalised boxes agree are compared
// voxel by voxel.

namespace osteon::detail {

namespace {

void set_voxel(VoxelGrid& grid, int x, int y, int z) {
  const int v = x + kVoxelSide * (y + kVoxelSide * z);
  grid.bits[size_t(v) / 64] |= uint64_t{1} << (v % 64);
}

int clamp_cell(double c) {
  if (!(c >= 0)) return 0;  // NaN-safe
  return std::min(kVoxelSide - 1, int(c));
}

}  // namespace

int VoxelGrid::occupied() const {
  int n = 0;
  for (uint64_t w : bits) n += std::popcount(w);
  return n;
}

VoxelGrid voxelize(const Mesh& mesh, const Pose& pose, const Mat3& turn) {
  const Mat3 frame = multiply(turn, pose.axes);
  const double inverse_scale = 1.0 / pose.scale;
  std::vector<char> used(mesh.positions.size(), 0);
  for (uint32_t i : mesh.indices) used[i] = 1;
  std::vector<Vec3d> y(mesh.positions.size());
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  bool first = true;
  for (size_t v = 0; v < y.size(); ++v) {
    if (!used[v]) continue;
    y[v] = inverse_scale * multiply(frame, to_double(mesh.positions[v]) - pose.centroid);
    const double c[3] = {y[v].x, y[v].y, y[v].z};
    for (int k = 0; k < 3; ++k) {
      lo[k] = first ? c[k] : std::min(lo[k], c[k]);
      hi[k] = first ? c[k] : std::max(hi[k], c[k]);
    }
    first = false;
  }
  // Voxels per unit along each axis; a side of (nearly) zero length is a single layer.
  double per_unit[3];
  for (int k = 0; k < 3; ++k) {
    const double side = hi[k] - lo[k];
    per_unit[k] = side > 1e-9 ? kVoxelSide / side : 0.0;
  }
  for (size_t v = 0; v < y.size(); ++v) {
    if (!used[v]) continue;
    y[v] = {(y[v].x - lo[0]) * per_unit[0], (y[v].y - lo[1]) * per_unit[1],
            (y[v].z - lo[2]) * per_unit[2]};
  }

  VoxelGrid grid;
  const size_t triangles = mesh.triangle_count();
  for (size_t t = 0; t < triangles; ++t) {
    const Vec3d a = y[mesh.indices[3 * t]];
    const Vec3d ab = y[mesh.indices[3 * t + 1]] - a;
    const Vec3d ac = y[mesh.indices[3 * t + 2]] - a;
    const Vec3d bc = ac - ab;
    const double longest =
        std::sqrt(std::max({squared_length(ab), squared_length(ac), squared_length(bc)}));
    // n steps along each edge, at most a third of a voxel apart (a box side is 16 voxels, so
    // n <= 3 * 16 * sqrt(3) + 1).
    const int n = std::max(1, int(std::ceil(3.0 * longest)));
    const double step = 1.0 / n;
    for (int i = 0; i <= n; ++i) {
      for (int j = 0; i + j <= n; ++j) {
        const Vec3d p = a + (step * i) * ab + (step * j) * ac;
        set_voxel(grid, clamp_cell(p.x), clamp_cell(p.y), clamp_cell(p.z));
      }
    }
  }
  return grid;
}

VoxelGrid flip_axes(const VoxelGrid& grid, unsigned mask) {
  if ((mask & 7u) == 0) return grid;
  VoxelGrid out;
  constexpr int kLast = kVoxelSide - 1;
  for (int v = 0; v < kVoxelCount; ++v) {
    if (!((grid.bits[size_t(v) / 64] >> (v % 64)) & 1)) continue;
    int x = v % kVoxelSide, y = (v / kVoxelSide) % kVoxelSide, z = v / (kVoxelSide * kVoxelSide);
    if (mask & 1u) x = kLast - x;
    if (mask & 2u) y = kLast - y;
    if (mask & 4u) z = kLast - z;
    set_voxel(out, x, y, z);
  }
  return out;
}

VoxelSimilarity voxel_similarity(const VoxelGrid& a, const VoxelGrid& b) {
  int differ = 0, both = 0, either = 0;
  for (size_t w = 0; w < a.bits.size(); ++w) {
    differ += std::popcount(a.bits[w] ^ b.bits[w]);
    both += std::popcount(a.bits[w] & b.bits[w]);
    either += std::popcount(a.bits[w] | b.bits[w]);
  }
  VoxelSimilarity s;
  s.phi = double(kVoxelCount - differ) / kVoxelCount;
  s.jaccard = either > 0 ? double(both) / either : 1.0;
  return s;
}

}  // namespace osteon::detail
