// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "osteon/mesh.hpp"

// Based on: the usual half-edge bookkeeping (pmp-library's SurfaceMesh checks, MeshLab's
// "Compute Topological Measures"): edges are unordered vertex pairs, counted over triangles.

namespace osteon {

/// Topology and measures of one connected component (triangles connected through shared vertices).
struct ComponentReport {
  size_t vertices = 0;  ///< vertices referenced by the component's triangles
  size_t triangles = 0;
  size_t edges = 0;
  size_t boundary_edges = 0;     ///< edges used by exactly one triangle
  size_t boundary_loops = 0;     ///< closed walks of boundary edges (see DiagnosisReport)
  size_t nonmanifold_edges = 0;  ///< edges used by three or more triangles
  size_t nonmanifold_vertices = 0;
  size_t inconsistent_edges = 0;  ///< two-triangle edges both triangles traverse the same way
  long euler = 0;                 ///< V - E + F
  /// (2 - euler - boundary_loops) / 2 for an oriented 2-manifold component; -1 where the component
  /// is not an orientable manifold (non-manifold edges or vertices, or inconsistent orientation),
  /// where genus is not defined by that formula.
  long genus = -1;
  bool closed = false;  ///< no boundary and no non-manifold edge
  Aabb bbox;
  double area = 0;
  double volume = 0;  ///< signed, by the divergence theorem; meaningful for closed oriented parts
};

/// The whole mesh: totals over its components plus the per-component list (largest first).
struct DiagnosisReport {
  size_t vertices = 0;  ///< all positions, referenced or not
  size_t unreferenced_vertices = 0;
  size_t triangles = 0;
  size_t degenerate_triangles = 0;  ///< repeated index or zero area (they are still counted above)
  size_t components = 0;
  size_t edges = 0;
  size_t boundary_edges = 0;
  /// Boundary loops: boundary edges are chained at each vertex by following the triangle fan; at
  /// a vertex where several boundary loops touch, the walk pairs edges in the fan order, so a
  /// figure-of-eight counts as two loops.
  size_t boundary_loops = 0;
  size_t nonmanifold_edges = 0;
  /// Vertices whose triangles form more than one fan (a "bow tie"), or that lie on a
  /// non-manifold edge.
  size_t nonmanifold_vertices = 0;
  size_t inconsistent_edges = 0;
  long euler = 0;   ///< V - E + F over all positions (unreferenced ones count as isolated vertices)
  long genus = -1;  ///< sum over components when every component has one, else -1
  bool closed = false;    ///< no boundary and no non-manifold edge; an empty mesh is not closed
  bool oriented = false;  ///< closed, and no inconsistent edge
  Aabb bbox;
  double area = 0;
  double volume = 0;
  std::vector<ComponentReport> component_reports;  ///< largest (by triangles) first
  /// The component of each triangle, numbered in the order of component_reports.
  std::vector<uint32_t> triangle_component;
};

/// Measures the topology and geometry of `mesh`. Complexity O(n log n) time, O(n) memory.
DiagnosisReport diagnose(const Mesh& mesh);

}  // namespace osteon
