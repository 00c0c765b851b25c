// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>

#include "osteon/mesh.hpp"
#include "osteon/status.hpp"

// Based on: P. Cignoni, C. Rocchini, R. Scopigno, "Metro: measuring error on simplified surfaces",
// Computer Graphics Forum 17(2), 1998 (samples on the vertices, edges and faces of one surface,
// each measured to the other surface; one-sided and symmetric max, mean and RMS); C. Ericson,
// "Real-Time Collision Detection", 2005, section 5.1.5 (the closest point of a triangle by its
// Voronoi regions); bounding-volume hierarchies for closest-point queries (a binary tree of
// axis-aligned boxes, nearer child first, pruned by the best distance so far).
//
// What the figures are: every distance is exact from a sample point to the other surface; the
// sample points are a finite set, so the maximum is a sampled LOWER BOUND of the true one-sided
// Hausdorff distance, and mean and RMS are estimates of the surface averages. docs/DESIGN.md
// ("Measuring geometric error") gives how tight the bound is at the default density.

namespace osteon {

/// The closest point of a surface to a query point.
struct ClosestPoint {
  static constexpr uint32_t kNoTriangle = std::numeric_limits<uint32_t>::max();
  /// Euclidean, >= 0.
  double distance = std::numeric_limits<double>::infinity();
  /// The closest point on the surface.
  Vec3d point;
  /// The mesh triangle it lies on (where several are equally near, the first found).
  uint32_t triangle = kNoTriangle;
};

/// The point of triangle (a, b, c) closest to `p`, exact up to double rounding (Voronoi regions
/// of the vertices, edges and face). Degenerate triangles (zero area: collinear or repeated
/// corners, or a sine below 1e-10 at the first corner) are measured as their three edges.
/// `triangle` is left kNoTriangle. O(1).
ClosestPoint closest_point_on_triangle(const Vec3d& p, const Vec3d& a, const Vec3d& b,
                                       const Vec3d& c);

/// Many closest-point queries against one mesh: a bounding-volume hierarchy over its triangles
/// (median splits along the longest axis of the triangle centroids, at most 4 triangles a leaf,
/// built in parallel), queried depth-first, nearer child first, pruned by the best distance so
/// far (boxes tested in float with a slack that covers float rounding, so no nearer triangle is
/// ever skipped), with the exact point-to-triangle distance at the leaves. Immutable once built,
/// so one query object serves any number of threads.
/// Memory: about 65 bytes a triangle (16 more while building). Build O(T log T); a query about
/// O(log T) on typical meshes.
class DistanceQuery {
 public:
  /// Builds the hierarchy over every triangle of `mesh` (degenerate triangles included: they are
  /// segments or points of the surface). Errors name mesh.source (else mesh.name):
  /// kInvalidArgument for a mesh without triangles or with an index out of range, kInvalidData
  /// for a non-finite coordinate.
  static Result<DistanceQuery> build(const Mesh& mesh);

  DistanceQuery(DistanceQuery&&) noexcept;
  DistanceQuery& operator=(DistanceQuery&&) noexcept;
  ~DistanceQuery();

  /// The closest point of the mesh's surface to `p`. Deterministic: the same point gives the same
  /// answer whatever ran before.
  ClosestPoint closest(const Vec3d& p) const;
  /// The same, starting from triangle `hint` (any triangle id; kNoTriangle for none): its
  /// distance bounds the search from the start, which makes queries much faster when `hint` is
  /// the answer of a nearby earlier query. The distance is the same as without a hint up to
  /// double rounding; where two triangles are equally near, the triangle and point may differ.
  ClosestPoint closest(const Vec3d& p, uint32_t hint) const;
  /// The same, but done as soon as a triangle within `enough` of `p` is found: that triangle is
  /// the answer then (its distance <= enough, not always the nearest). When no triangle is that
  /// near, the answer is the nearest, as closest(p, hint) gives it. For the largest distance of
  /// many points, with `enough` the largest so far: most points end at their first triangle.
  ClosestPoint closest(const Vec3d& p, uint32_t hint, double enough) const;

  size_t triangle_count() const;
  /// The box of the mesh's triangles.
  Aabb bounds() const;

 private:
  struct Impl;
  explicit DistanceQuery(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// Where the edge samples go along the mesh's unique edges, laid end to end.
enum class EdgeSampling {
  /// Metro's and MeshLab's rule: the samples are shared out in proportion to length (the
  /// fraction carried from edge to edge), and an edge given m of them gets its m evenly spaced
  /// interior points i / (m + 1). No randomness. It under-weights the edges' ends, so where the
  /// distance peaks at the vertices (noise on vertices) the edge samples' mean is a few percent
  /// below the length average.
  kEvenlySpaced,
  /// One point at a seeded random position in each of n equal stretches of length: uniform by
  /// length, an unbiased estimate of the distance averaged along the edges.
  kStratified,
};

struct HausdorffOptions {
  /// Sample points on each sampled mesh (each direction); 0: samples_per_face x its triangles.
  /// They are split as MeshLab's Hausdorff filter splits SampleNum (so that both can be run at
  /// the same count): min(vertices, samples / 3) vertex samples, the rest shared equally by edges
  /// and faces (an edge or face share goes to the other kind when all edges or faces have zero
  /// size).
  uint64_t samples = 0;
  double samples_per_face = 10;  ///< Metro's default density
  /// Seeds the random positions; the same seed gives the same figures bit for bit, whatever the
  /// number of threads.
  uint64_t seed = 1;
  bool sample_vertices = true;
  bool sample_edges = true;
  bool sample_faces = true;
  EdgeSampling edge_sampling = EdgeSampling::kEvenlySpaced;
  /// Only the largest distance is wanted: a sample is measured only as far as it could raise the
  /// largest so far (DistanceQuery::closest with `enough`). max is the same as without it, bit
  /// for bit, and max_at and max_closest are a sample at that distance and its closest point;
  /// mean and rms are left 0. Several times faster where the surfaces are close.
  bool max_only = false;
  /// With max_only: a distance already known from elsewhere (the other direction, say), below
  /// which nothing is wanted. Samples are measured only as far as they could exceed it, so max is
  /// exact where it exceeds known_max and otherwise some distance no larger than it.
  double known_max = 0;
  /// Worker threads; 0 (or more than the cores): every core.
  int threads = 0;
  /// Called on the calling thread after each slice of about 260k samples with the samples done
  /// and the total (both directions for hausdorff()); for progress bars. May be empty.
  std::function<void(uint64_t done, uint64_t total)> progress;
};

/// Distances from the samples on one mesh to the other mesh (or both ways, for the symmetric
/// figure). Relative values divide by `diagonal`.
struct OneSidedDistance {
  double max = 0;   ///< largest sample distance: a lower bound of the true Hausdorff distance
  double mean = 0;  ///< mean of the sample distances (vertex, edge and face samples alike)
  double rms = 0;   ///< root mean square of the sample distances
  /// Bounding-box diagonal of the sampled mesh (symmetric: of both meshes together).
  double diagonal = 0;
  uint64_t samples = 0;
  uint64_t vertex_samples = 0;
  uint64_t edge_samples = 0;
  uint64_t face_samples = 0;
  Vec3d max_at;       ///< the sample of the largest distance (on the sampled mesh)
  Vec3d max_closest;  ///< its closest point on the other mesh

  /// max, mean and rms / diagonal; nullopt when the diagonal is 0 (a mesh of one point).
  std::optional<double> max_relative() const { return relative(max); }
  std::optional<double> mean_relative() const { return relative(mean); }
  std::optional<double> rms_relative() const { return relative(rms); }

 private:
  std::optional<double> relative(double v) const {
    return diagonal > 0 ? std::optional<double>(v / diagonal) : std::nullopt;
  }
};

struct HausdorffReport {
  OneSidedDistance forward;   ///< samples on a, distances to b
  OneSidedDistance backward;  ///< samples on b, distances to a
  /// The larger of forward and backward for max, mean and rms (Metro's symmetric figure; max
  /// is the symmetric Hausdorff distance), samples of both, max_at and max_closest from the
  /// direction of the larger max, diagonal of both meshes' box.
  OneSidedDistance symmetric;
};

/// Distances from samples on `sampled` to the surface `target` was built on: `options.samples`
/// (or samples_per_face x triangles) points on the vertices, edges and faces of `sampled` (edge
/// samples as options.edge_sampling says; face samples stratified by area, one at a seeded
/// uniform random point of each stratum), each measured exactly to the target surface.
/// Distances below 2^-32 x the largest coordinate magnitude of both meshes (rounding, not
/// geometry) are counted as 0, so a mesh against itself measures exactly 0.
/// Errors: those of DistanceQuery::build for `sampled`, naming its source; options as hausdorff().
/// Known approximation: the max is a sampled lower bound of the one-sided Hausdorff distance.
/// Complexity: O(S log T) for S samples and T target triangles, in parallel over the samples.
Result<OneSidedDistance> one_sided_distance(const Mesh& sampled, const DistanceQuery& target,
                                            const HausdorffOptions& options = {});

/// The Metro measurement of a against b: forward (a sampled, to b), backward (b sampled, to a)
/// and symmetric. Builds a DistanceQuery on each mesh.
/// Errors: a mesh without triangles, with an index out of range (kInvalidArgument) or a
/// non-finite coordinate (kInvalidData), the message naming that mesh's source (else its name);
/// options.samples_per_face not > 0 or options.threads < 0 (kInvalidArgument).
/// Known approximation: every max is a sampled lower bound of the true Hausdorff distance.
Result<HausdorffReport> hausdorff(const Mesh& a, const Mesh& b,
                                  const HausdorffOptions& options = {});

/// The paper's relative errors, eq. (10)-(12) of Zhou, Jia & Su (2018):
/// E = |d(X, Y) - d(X, X)| / d(X, X) for d = max, mean and RMS, where X is the original and Y
/// the processed mesh. Each is set only where it is defined, that is where d(X, X) > 0. As
/// printed, d(X, X) (a mesh's distance to itself) is 0 for every mesh, so the formula divides by
/// zero: osteon reports distances relative to the bounding-box diagonal instead
/// (OneSidedDistance::max_relative ...). See docs/DESIGN.md.
struct PaperRelativeErrors {
  std::optional<double> max, mean, rms;
};
PaperRelativeErrors paper_relative_errors(const OneSidedDistance& x_to_y,
                                          const OneSidedDistance& x_to_x);

}  // namespace osteon
