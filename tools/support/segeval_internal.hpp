// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "osteon/mesh.hpp"
#include "support/segeval.hpp"

// What tools/support/segeval.cpp (the .seg reader, the region measures and the averages) shares
// with tools/support/cut_discrepancy.cpp (the edge graph, the distance fields and CD).

namespace osteon::detail {

/// One mesh as the evaluator sees it, built once by SegmentationEvaluator::create.
struct EvaluationMesh {
  size_t vertex_count = 0;
  std::vector<double> face_area;  ///< per triangle, in double precision
  double area = 0;                ///< the sum of face_area
  double average_radius = 0;
  // The edge graph (CSR): vertex v's neighbours and the lengths of the edges to them are
  // [adjacency_offset[v], adjacency_offset[v + 1]) of adjacency and adjacency_length.
  std::vector<uint32_t> adjacency_offset;
  std::vector<uint32_t> adjacency;
  std::vector<double> adjacency_length;
  // Each edge with the triangles on it: edge e joins edge_vertices[2e] and edge_vertices[2e + 1]
  // and carries the triangles edge_faces[edge_face_offset[e] .. edge_face_offset[e + 1]).
  std::vector<uint32_t> edge_vertices;
  std::vector<uint32_t> edge_face_offset;
  std::vector<uint32_t> edge_faces;
};

/// Fills the edge graph and the edge-triangle lists of `out` from `mesh` (an edge is an unordered
/// pair of distinct vertices of a triangle; a repeated index gives no edge). O(T log T).
void build_edge_graph(const Mesh& mesh, EvaluationMesh* out);

/// segEval's R3Mesh::AverageRadius: sum(area_t * |centroid_t - c|) / sum(area_t), where
/// centroid_t is the mean of triangle t's corners and c the area-weighted mean of the centroids.
/// 0 when the total area is 0.
double average_radius(const Mesh& mesh, const std::vector<double>& face_area);

/// The endpoints of every edge whose triangles do not all carry the same label, sorted.
std::vector<uint32_t> find_cut_vertices(const EvaluationMesh& mesh,
                                        const std::vector<uint32_t>& labels);

/// Multi-source Dijkstra along the mesh edges: per vertex, the length of the shortest edge path
/// to any of `sources` (+infinity where none is reachable). O((V + E) log V).
std::vector<double> distances_from(const EvaluationMesh& mesh,
                                   const std::vector<uint32_t>& sources);

/// segEval's cut discrepancy of two prepared segmentations (see SegmentationScores).
std::optional<double> cut_discrepancy(const EvaluationMesh& mesh, const PreparedSegmentation& a,
                                      const PreparedSegmentation& b);

}  // namespace osteon::detail
