// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <vector>

#include "osteon/mesh.hpp"

// The dual graph segmentation diffuses over: one node per triangle, one arc per pair of
// triangles that share an edge, weighted by the paper's global distance GD (eq. 2). Built once
// per mesh in O(T log T) (a sort of the 3T edges), stored as compressed rows.

namespace osteon::detail {

struct DualGraphOptions {
  double phi = 300;        ///< weight of the angular distance (paper: 300)
  double convex_eta = 0.02;  ///< eta of AD on convex edges (SegmentOptions); 1 on concave
};

struct DualGraph {
  /// Arcs of triangle t: first[t] .. first[t + 1] (both directions stored).
  std::vector<uint32_t> first;
  std::vector<uint32_t> target;  ///< the neighbouring triangle
  std::vector<float> weight;     ///< GD: (CD + phi * AD * mean CD) / bbox diagonal
  std::vector<float> concavity;  ///< AD of the shared edge (eta (1 - cos theta))
  std::vector<float> length;     ///< length of the shared edge, in mesh units
  std::vector<Vec3> centroid;    ///< per triangle
  std::vector<double> area;      ///< per triangle
  double diagonal = 0;           ///< bounding-box diagonal (beta)
  double mean_cd = 0;            ///< mean centroid distance over the edges

  uint32_t triangles() const { return static_cast<uint32_t>(centroid.size()); }
};

/// Builds the dual graph. Triangles meet across an edge used by exactly two of them; across a
/// non-manifold edge (three or more) every pair is joined, across a boundary edge none.
DualGraph build_dual_graph(const Mesh& mesh, const DualGraphOptions& options);

/// Labels the edge-connected parts of the dual graph 0, 1, ... in order of their first triangle;
/// returns the count.
uint32_t label_dual_parts(const DualGraph& graph, std::vector<uint32_t>* part);

}  // namespace osteon::detail
