// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "osteon/hausdorff.hpp"
#include "osteon/mesh.hpp"

// What the repeat finder's files share: the pose normalisation (src/pose.cpp), the 16^3 voxel
// similarity (src/voxel_similarity.cpp), the similarity fit and ICP (src/icp.cpp), used by the
// candidate search and grouping (src/repeats.cpp). Plain arrays, no Eigen types: Eigen stays
// inside the .cpp files (a private dependency of the library).

namespace osteon::detail {

/// A 3x3 matrix, row-major.
using Mat3 = std::array<double, 9>;
constexpr Mat3 kIdentity3 = {1, 0, 0, 0, 1, 0, 0, 0, 1};

Mat3 multiply(const Mat3& a, const Mat3& b);
Mat3 transpose(const Mat3& a);
double determinant(const Mat3& a);
Vec3d multiply(const Mat3& a, const Vec3d& v);

/// How far the principal axes of a component are determined by its second moments.
enum class AxisAmbiguity : uint8_t {
  kNone,   ///< three distinct moments: the axes are fixed up to sign
  kPlane,  ///< two equal moments (a cylinder, a disc): free rotation about `distinct_axis`
  kFull,   ///< three equal moments (a sphere, a cube): any rotation
};

/// A component's pose normalisation (paper eq. (5)-(9), area-weighted, plus the principal axes):
/// canonical coordinates y = axes * (x - centroid) / scale.
struct Pose {
  Vec3d centroid;          ///< area-weighted centroid of the surface (eq. (5))
  double area = 0;         ///< surface area
  double scale = 0;        ///< RMS distance of the surface from the centroid
  Mat3 axes = kIdentity3;  ///< rows: principal axes, largest moment first, signs chosen; det +-1
  /// Principal moments (eigenvalues of the area-weighted covariance) / their sum, descending.
  std::array<double, 3> moments{};
  /// Skewness of the surface along each axis (third moment / the axis's standard deviation
  /// cubed), after the sign choice (>= 0).
  std::array<double, 3> skew{};
  /// |skew| too small for its sign to be trusted: both signs are tried.
  std::array<bool, 3> sign_free{};
  AxisAmbiguity ambiguity = AxisAmbiguity::kNone;
  int distinct_axis = 0;  ///< for kPlane: the axis whose moment differs (0 or 2)
  /// The normalised AABB: canonical coordinates of the vertices.
  std::array<double, 3> box_min{}, box_max{};
  /// Largest distance of a vertex from each canonical axis, and from the centroid (normalised).
  std::array<double, 3> radial{};
  double radius = 0;
};

/// Pose thresholds (docs/DESIGN.md, "Repeated components").
struct PoseOptions {
  /// Two principal moments count as equal when they differ by less than this fraction of the
  /// larger.
  double equal_moments = 0.1;
  /// A skewness below this leaves the axis's sign free.
  double free_sign_skew = 0.1;
};

/// The pose of `mesh` (already checked: triangles, indices in range, finite positions). False for
/// a mesh of zero area, which has none. O(V + T).
bool compute_pose(const Mesh& mesh, const PoseOptions& options, Pose* pose);

/// The canonical coordinates of x.
Vec3d to_canonical(const Pose& pose, const Vec3d& x);

/// The ambiguity two components must be compared under: the greater of theirs; kFull too when
/// both are kPlane about different axes. `distinct_axis` is set for kPlane.
AxisAmbiguity combined_ambiguity(const Pose& a, const Pose& b, int* distinct_axis);

/// The rotations (and reflections) Q to try between two components' canonical frames, y_a = Q
/// y_b, for the ambiguities of either: sign flips of free axes; for kPlane, 24 rotations about the
/// distinct axis, each with and without a reflection in the plane; for kFull, 320 rotations
/// (40 directions for the first axis, 8 turns about it) with and without a reflection. The
/// identity comes first.
std::vector<Mat3> pose_alternatives(const Pose& a, const Pose& b);

constexpr int kVoxelSide = 16;
constexpr int kVoxelCount = kVoxelSide * kVoxelSide * kVoxelSide;  // 4096, the paper's N

/// Surface occupancy of 16^3 voxels spanning a box: voxel x + 16 y + 256 z is bit (v % 64) of
/// word v / 64.
struct VoxelGrid {
  std::array<uint64_t, kVoxelCount / 64> bits{};
  int occupied() const;
};

/// Voxelises `mesh` in its canonical frame turned by `turn` (y' = turn * y), over the AABB of the
/// turned vertices split into 16 voxels a side (each voxel the box's sides / 16; a side of zero
/// length is one layer). A voxel is occupied when a point of a barycentric grid on a triangle,
/// spaced at most a third of a voxel, falls in it. O(T + area / voxel area).
VoxelGrid voxelize(const Mesh& mesh, const Pose& pose, const Mat3& turn);

/// The same grid with the axes in `mask` (bit k: axis k) reversed: what voxelize gives for the
/// canonical frame with those axes' signs flipped.
VoxelGrid flip_axes(const VoxelGrid& grid, unsigned mask);

struct VoxelSimilarity {
  double phi = 0;      ///< paper eq. (3)-(4): the share of the 4096 voxels that agree
  double jaccard = 0;  ///< |A and B| / |A or B| (1 when both are empty)
};
VoxelSimilarity voxel_similarity(const VoxelGrid& a, const VoxelGrid& b);

/// x -> linear * x + translation, linear = scale * (orthogonal matrix, det +-1).
struct Similarity {
  Mat3 linear = kIdentity3;
  Vec3d translation;
};
Vec3d apply(const Similarity& s, const Vec3d& x);
Similarity inverse(const Similarity& s);
/// The uniform scale of a similarity: cbrt(|det linear|).
double similarity_scale(const Similarity& s);

/// Least-squares similarity taking from[i] to to[i] (Umeyama), with a determinant of sign
/// `det_sign` (+1 a rotation, -1 a reflection, 0 whichever fits better) and a scale of 1 unless
/// `allow_scale`. False when the points are too few or all coincide.
bool fit_similarity(const std::vector<Vec3d>& from, const std::vector<Vec3d>& to, int det_sign,
                    bool allow_scale, Similarity* out);

struct IcpResult {
  Similarity transform;
  double rms = 0;  ///< RMS of the last correspondences' distances (both directions)
  double max = 0;  ///< their largest
  int iterations = 0;
  bool gave_up = false;  ///< stopped early: the RMS stayed above give_up
};

/// One side of an ICP: the mesh, its samples (a subset of its vertices) and its distance query.
struct IcpSide {
  const Mesh* mesh = nullptr;
  const std::vector<Vec3d>* samples = nullptr;
  const DistanceQuery* query = nullptr;
};

/// How well `t` lines a up with b before any ICP: the RMS distance from each sample (of a,
/// moved by t; of b, moved back) to the nearest corner of its closest triangle on the other side,
/// in b's units. Ranks pose alternatives: unlike the distance to the surface, it tells the turns
/// of a sphere apart by their tessellation. O(samples * log T).
double corner_residual(const IcpSide& a, const IcpSide& b, const Similarity& t);

/// Symmetric point-to-point ICP from `start`, mapping a onto b: the samples of a (transformed) to
/// their closest points on b, and the samples of b (transformed back) to their closest points on
/// a, refitted by fit_similarity keeping the sign of start's determinant, until the RMS stops
/// falling (relative change below 1e-9); then the same with each closest point replaced by the
/// nearest corner of its triangle (exact correspondences for a copy with the same vertices).
/// At most `iterations` fits in all. The best transform seen (lowest RMS of the closest-point
/// distances) is returned. With give_up > 0 it stops early (gave_up) once, after 5 iterations, the
/// RMS is above give_up and not falling fast enough to go below it within twice `iterations`
/// more: a heuristic that spares the full run on shapes that do not match (it could drop a true
/// repeat whose ICP converges that slowly, never accept a wrong one).
/// O(iterations * samples * log T).
IcpResult icp(const IcpSide& a, const IcpSide& b, const Similarity& start, bool allow_scale,
              int iterations, double give_up = 0);

}  // namespace osteon::detail
