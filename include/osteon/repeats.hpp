// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "osteon/mesh.hpp"
#include "osteon/status.hpp"

// Based on: Zhou, Jia & Su, IEEE Access 6 (2018), section IV.C "Lightweight for shape" (AABB test,
// voxel similarity Phi of eq. (3)-(4) at 4096 voxels, pose alignment of eq. (5)-(9)); principal
// axes of the area-weighted covariance for the rotation (Vranic & Saupe's continuous PCA, 2001);
// P. Besl, N. McKay, "A method for registration of 3-D shapes", IEEE PAMI 14(2), 1992 (ICP);
// S. Umeyama, "Least-squares estimation of transformation parameters between two point
// patterns", IEEE PAMI 13(4), 1991 (the similarity fit, here keeping a reflection when asked).
//
// A skeleton repeats itself: left and right bones, ribs, vertebrae, phalanges, the same bone twice.
// find_repeats() finds components that are copies of one another under a similarity transform
// (moved, rotated, mirrored, uniformly scaled), so that each shape is sent once and its repeats
// drawn with a 4x4 matrix. Every substitution is verified: the matrix applied to the prototype
// reproduces the member within a measured (symmetric, sampled) Hausdorff distance that is below
// the tolerance. docs/DESIGN.md ("Repeated components") gives the steps and why.

namespace osteon {

struct RepeatOptions {
  /// The tolerance of a substitution, absolute in mesh units; > 0 overrides the codec's bound.
  double tolerance = 0;
  /// With tolerance 0, the tolerance of each member is the codec's own error bound for it: half a
  /// grid step times sqrt(3) (every coordinate within half a step), the step being the member's
  /// largest bounding-box side / (2^bits - 1), as encode() chooses it, or 2 * precision when
  /// precision > 0 (EncodeOptions's meaning). bits 8..24. It is never below what the stored
  /// coordinates' own rounding allows: where every coordinate of a component is a multiple of a
  /// decimal step r (a file written with 6 decimals), two exact copies differ by up to
  /// sqrt(3) / 2 (s r_prototype + r_member), s the copy's scale (docs/DESIGN.md).
  int bits = 14;
  double precision = 0;
  /// Accept copies of another size (a uniform scale in the matrix). Off: rigid motions and
  /// reflections only (a scale more than aabb_tolerance from 1 is rejected before voxelising).
  bool allow_scale = true;
  /// Accept mirror images (a matrix of negative determinant).
  bool allow_mirror = true;

  /// Candidate tests, in the order they run. Pose descriptor: the normalised principal moments
  /// (eigenvalues / their sum) of two components differ by at most this much each ...
  double descriptor_tolerance = 0.03;
  /// ... and their area / RMS radius^2 by at most this fraction.
  double area_tolerance = 0.1;
  /// Normalised bounding boxes (in the principal frame, divided by the RMS radius): each side
  /// agrees within this fraction of the larger.
  double aabb_tolerance = 0.1;
  /// The paper's voxel similarity: the share of the 16^3 voxels whose occupancy agrees must exceed
  /// this (paper: 0.9) ...
  double phi_threshold = 0.9;
  /// ... and the Jaccard index of the occupied voxels (|A and B| / |A or B|) must reach this. Phi
  /// counts the many empty voxels both share, so alone it lets quite different shapes through;
  /// 0 switches this extra filter off.
  double min_jaccard = 0.5;

  /// ICP: closest-point samples a side (the component's vertices, evenly strided) and iterations.
  uint32_t icp_samples = 1000;
  int icp_iterations = 40;
  /// Hausdorff samples a direction in the verification; 0: 3 x the sampled component's vertices
  /// (so every vertex is a sample), at least 600 and at most 30,000.
  uint64_t hausdorff_samples = 0;

  /// For bytes_saved: the codec's cost of a triangle at 14 bits (about 13 bits: 26 bits a vertex
  /// on the BodyParts3D bones in docs/BENCHMARKS.md, two triangles a vertex), and what an
  /// instance costs instead (a 4x4 float matrix).
  double bytes_per_triangle = 1.6;
  size_t bytes_per_instance = 64;
  /// Worker threads; 0: every core.
  int threads = 0;
};

/// One repeat: component `part` is the group's prototype transformed by `matrix`.
struct RepeatMember {
  size_t part = 0;
  /// Column-major 4x4: maps the prototype's vertices onto the member's (m[12..14] translation).
  std::array<double, 16> matrix{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  bool mirror = false;  ///< the matrix's determinant is negative
  double scale = 1;     ///< its uniform scale
  /// Symmetric Hausdorff distance between the transformed prototype and the member, in mesh
  /// units. Known approximation: a sampled lower bound (hausdorff.hpp), every vertex of both
  /// sampled when there are at most 10,000.
  double hausdorff = 0;
  double tolerance = 0;  ///< what it was accepted under
  double phi = 0;        ///< voxel similarity of the pose alternative that verified
  double jaccard = 0;
};

struct RepeatGroup {
  size_t prototype = 0;
  std::vector<RepeatMember> members;  ///< by part index
};

/// How many pairs each stage saw. A pair is an unordered pair of components.
struct RepeatCounters {
  size_t components = 0;
  size_t skipped = 0;             ///< components of zero area (never grouped)
  uint64_t pairs_total = 0;       ///< n (n - 1) / 2
  uint64_t pairs_considered = 0;  ///< in neighbouring cells of the descriptor grid
  uint64_t pairs_descriptor = 0;  ///< passing the descriptor test
  uint64_t pairs_aabb = 0;        ///< passing the normalised AABB test too
  /// Voxel similarity is evaluated lazily, only between a prototype and the components not yet
  /// assigned: pairs among the members of one group are never voxelised.
  uint64_t pairs_phi_evaluated = 0;
  uint64_t pairs_phi = 0;           ///< passing Phi (and the Jaccard filter)
  uint64_t pairs_verified = 0;      ///< ICP + Hausdorff run
  uint64_t pairs_accepted = 0;      ///< within tolerance: substituted
  uint64_t rejected_hausdorff = 0;  ///< verified but beyond tolerance
  uint64_t pose_alternatives = 0;   ///< voxel comparisons over all pairs (symmetry alternatives)
};

/// Wall-clock milliseconds of each stage.
struct RepeatTimings {
  double pose_ms = 0;        ///< pose normalisation and voxelisation of every component
  double candidates_ms = 0;  ///< descriptor grid and AABB test
  double phi_ms = 0;         ///< voxel similarity
  double verify_ms = 0;      ///< ICP and Hausdorff
  double total_ms = 0;
};

struct RepeatReport {
  std::vector<RepeatGroup> groups;  ///< by prototype index; only groups with members
  size_t members = 0;               ///< components drawn as instances
  uint64_t triangles_saved = 0;     ///< the members' triangles
  /// Estimated: each member's triangles x bytes_per_triangle, less bytes_per_instance.
  uint64_t bytes_saved = 0;
  double largest_error = 0;  ///< the largest member hausdorff
  RepeatCounters counters;
  RepeatTimings timings;
};

/// Finds the repeated components among `components` (any meshes: one bone each, typically) and
/// groups them greedily: components in order of decreasing area (ties by index); each one not yet
/// assigned becomes a prototype and takes every later unassigned component that passes the
/// candidate tests (pose descriptor, normalised AABB, voxel similarity) and the verification (ICP
/// from the pose alignment, then a symmetric Hausdorff distance within the member's tolerance).
/// A member is never a prototype. Deterministic: the same input gives the same report, whatever
/// the number of threads.
/// Errors: kInvalidArgument for a component without triangles or with an index out of range
/// (naming it and its index) and for options out of range; kInvalidData for a non-finite
/// coordinate. Components of zero area are skipped (counted, never grouped).
/// Known approximations: the Hausdorff figure is a sampled lower bound; a repeat whose pose
/// alignment is ambiguous beyond the alternatives tried (docs/DESIGN.md) can be missed, never
/// wrongly accepted.
/// Complexity: O(n log n + W) candidate tests for W pairs in neighbouring descriptor cells (near
/// O(n log n) when shapes differ), O(V) per voxel comparison, O(S log T) per verification.
Result<RepeatReport> find_repeats(const std::vector<Mesh>& components,
                                  const RepeatOptions& options = {});

/// options.tolerance when > 0, else the codec's error bound for `member` (RepeatOptions::bits,
/// precision). find_repeats applies this, raised where needed to the coordinates' own rounding.
double repeat_tolerance(const Mesh& member, const RepeatOptions& options);

/// The vertex-connected pieces of a mesh (triangles sharing a vertex are one piece), each a mesh
/// of its own with only its vertices, in order of their first triangle, named "name#k" (k from 0)
/// when there are several, with the mesh's source, unit, colour and label; a mesh of one piece
/// comes back whole. Lets a file that holds many bones
/// (an STL of a whole spine) be searched for repeats bone by bone. O(V + T).
std::vector<Mesh> split_connected(const Mesh& mesh);

/// The vertex-connected piece of each triangle of `mesh`, as split_connected cuts them, numbered
/// from 0 in order of their first triangle; `pieces` receives their count. Precondition: every
/// index is in range. O(V + T).
std::vector<uint32_t> connected_pieces(const Mesh& mesh, uint32_t* pieces);

}  // namespace osteon
