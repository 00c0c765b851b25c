// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <vector>

#include "osteon/mesh.hpp"
#include "osteon/status.hpp"

// Segmentation (paper section IV.B): a mesh is split into connected parts, then each part into
// components by Dijkstra region diffusion on the dual graph weighted by the paper's global
// distance GD = (CD + phi * AD) / beta, so that components follow the concave creases between
// anatomical (or any) parts and none is too large to stream and decode quickly. The algorithm and
// the reading of the paper it takes are in docs/DESIGN.md ("Segmentation").

namespace osteon {

struct SegmentOptions {
  /// Weight of the angular distance AD against the centroid distance CD (paper: 300; 0 ignores
  /// the creases and cuts by geodesic distance only).
  double phi = 300;
  /// Katz & Tal's eta for convex edges (concave edges have 1): how much a convex edge resists.
  /// Katz & Tal use 0.1-0.2 with AD weighed equally with distance; at phi = 300 a convex edge
  /// resists enough at 0.02 (best of 0.01-0.3 on the Princeton benchmark, bench/segmentation).
  double convex_eta = 0.02;
  /// Target number of components for the whole mesh; 0: as many as the creases call for (see
  /// merge_concavity). A mesh with more connected parts than this keeps one per part.
  uint32_t segments = 0;
  /// The largest component wanted, in triangles (0: no limit). Larger ones are split, and
  /// segments is exceeded where it must be.
  uint32_t max_triangles = 0;
  /// Rounds of re-centring the regions and diffusing again (paper steps 4-6).
  uint32_t iterations = 3;
  /// With segments = 0: regions whose shared boundary is on average less concave than this
  /// (in AD, 1 - cos of the dihedral angle) are merged.
  double merge_concavity = 0.04;
};

struct Segmentation {
  /// Component of every triangle of the input, 0 .. count - 1, numbered in order of their first
  /// triangle.
  std::vector<uint32_t> labels;
  uint32_t count = 0;  ///< components
  uint32_t parts = 0;  ///< edge-connected parts of the input
};

/// Segments a mesh. Every triangle is labelled, degenerate ones included (they join a
/// neighbour). Errors: kInvalidArgument for phi or convex_eta negative or not finite, or a
/// position that is not finite.
Result<Segmentation> segment(const Mesh& mesh, const SegmentOptions& options = {});

}  // namespace osteon
