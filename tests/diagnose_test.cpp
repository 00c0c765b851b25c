// SPDX-License-Identifier: Apache-2.0
#include "osteon/diagnose.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

#include "fixtures.hpp"
#include "osteon/io.hpp"
#include "osteon/mesh.hpp"
#include "support/phantom.hpp"

namespace osteon {
namespace {
namespace diagnose_test {

constexpr double kPi = 3.14159265358979323846;

Mesh mesh_of(std::vector<Vec3> positions, std::vector<uint32_t> indices) {
  Mesh mesh;
  mesh.positions = std::move(positions);
  mesh.indices = std::move(indices);
  mesh.stored_vertices = mesh.positions.size();
  return mesh;
}

/// Appends `b` to `a` as a separate set of vertices.
void append(Mesh& a, const Mesh& b) {
  const uint32_t base = static_cast<uint32_t>(a.positions.size());
  a.positions.insert(a.positions.end(), b.positions.begin(), b.positions.end());
  for (uint32_t i : b.indices) a.indices.push_back(base + i);
}

/// The invariants every report keeps, whatever the mesh.
void expect_consistent(const Mesh& mesh, const DiagnosisReport& r) {
  ASSERT_EQ(r.triangle_component.size(), mesh.triangle_count());
  ASSERT_EQ(r.component_reports.size(), r.components);
  size_t triangles = 0, vertices = 0, edges = 0, boundary = 0, loops = 0, nonmanifold = 0,
         nonmanifold_vertices = 0, inconsistent = 0;
  long euler = 0;
  for (size_t c = 0; c < r.components; ++c) {
    const ComponentReport& comp = r.component_reports[c];
    if (c > 0) {
      EXPECT_GE(r.component_reports[c - 1].triangles, comp.triangles) << "not sorted";
    }
    EXPECT_GT(comp.triangles, 0u);
    EXPECT_EQ(comp.euler, long(comp.vertices) - long(comp.edges) + long(comp.triangles));
    triangles += comp.triangles;
    vertices += comp.vertices;
    edges += comp.edges;
    boundary += comp.boundary_edges;
    loops += comp.boundary_loops;
    nonmanifold += comp.nonmanifold_edges;
    nonmanifold_vertices += comp.nonmanifold_vertices;
    inconsistent += comp.inconsistent_edges;
    euler += comp.euler;
  }
  std::vector<size_t> per_component(r.components, 0);
  for (uint32_t c : r.triangle_component) {
    ASSERT_LT(c, r.components);
    ++per_component[c];
  }
  for (size_t c = 0; c < r.components; ++c) {
    EXPECT_EQ(per_component[c], r.component_reports[c].triangles);
  }
  EXPECT_EQ(triangles, r.triangles);
  EXPECT_EQ(vertices + r.unreferenced_vertices, r.vertices);
  EXPECT_EQ(edges, r.edges);
  EXPECT_EQ(boundary, r.boundary_edges);
  EXPECT_EQ(loops, r.boundary_loops);
  EXPECT_EQ(nonmanifold, r.nonmanifold_edges);
  EXPECT_EQ(nonmanifold_vertices, r.nonmanifold_vertices);
  EXPECT_EQ(inconsistent, r.inconsistent_edges);
  EXPECT_EQ(euler + long(r.unreferenced_vertices), r.euler);
  EXPECT_EQ(r.euler, long(r.vertices) - long(r.edges) + long(r.triangles));
  EXPECT_EQ(r.oriented, r.closed && r.inconsistent_edges == 0);
  EXPECT_EQ(r.degenerate_triangles, count_degenerate_triangles(mesh));
}

TEST(Diagnose, EveryMeshCategory) {
  for (const test::NamedMesh& named : test::mesh_categories()) {
    SCOPED_TRACE(named.category);
    const DiagnosisReport r = diagnose(named.mesh);
    expect_consistent(named.mesh, r);
    if (named.category == "closed") {
      EXPECT_TRUE(r.closed);
      EXPECT_TRUE(r.oriented);
      EXPECT_EQ(r.genus, 0);
      EXPECT_EQ(r.euler, 2);
      EXPECT_GT(r.volume, 0);
    } else if (named.category == "open") {
      EXPECT_FALSE(r.closed);
      EXPECT_GT(r.boundary_loops, 0u);
      EXPECT_EQ(r.genus, 0);
    } else if (named.category == "genus1") {
      EXPECT_TRUE(r.oriented);
      EXPECT_EQ(r.genus, 1);
      EXPECT_EQ(r.euler, 0);
    } else if (named.category == "nonmanifold") {
      EXPECT_GT(r.nonmanifold_edges + r.nonmanifold_vertices, 0u);
      EXPECT_EQ(r.genus, -1);
    } else if (named.category == "multicomponent") {
      EXPECT_EQ(r.components, 2u);
      EXPECT_EQ(r.genus, 0);
      EXPECT_TRUE(r.oriented);
    } else if (named.category == "degenerate") {
      EXPECT_EQ(r.degenerate_triangles, 2u);
    }
    EXPECT_EQ(r.degenerate_triangles == 0, named.category != "degenerate");
  }
}

TEST(Diagnose, Icosphere) {
  const Mesh mesh = make_icosphere(4, 2.0f);
  const DiagnosisReport r = diagnose(mesh);
  expect_consistent(mesh, r);
  EXPECT_EQ(r.vertices, 2562u);
  EXPECT_EQ(r.triangles, 5120u);
  EXPECT_EQ(r.edges, 7680u);
  EXPECT_EQ(r.euler, 2);
  EXPECT_EQ(r.genus, 0);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.boundary_edges, 0u);
  EXPECT_EQ(r.boundary_loops, 0u);
  EXPECT_EQ(r.nonmanifold_vertices, 0u);
  EXPECT_TRUE(r.closed);
  EXPECT_TRUE(r.oriented);
  // An inscribed polyhedron: a little less than the sphere, within 0.5% at 5120 triangles.
  const double sphere_volume = 4.0 / 3.0 * kPi * 8.0, sphere_area = 4 * kPi * 4.0;
  EXPECT_LT(r.volume, sphere_volume);
  EXPECT_GT(r.volume, 0.995 * sphere_volume);
  EXPECT_LT(r.area, sphere_area);
  EXPECT_GT(r.area, 0.995 * sphere_area);
  // The midpoint of the icosahedron edge (0, -1, phi)-(0, 1, phi) is the pole (0, 0, 1).
  EXPECT_FLOAT_EQ(r.bbox.max.z, 2.0f);
  EXPECT_FLOAT_EQ(r.bbox.min.z, -2.0f);
}

TEST(Diagnose, BoxVolumeAndAreaAreExact) {
  const Mesh mesh = make_box({0, 0, 0}, {1, 2, 3});
  const DiagnosisReport r = diagnose(mesh);
  expect_consistent(mesh, r);
  EXPECT_EQ(r.vertices, 8u);
  EXPECT_EQ(r.edges, 18u);
  EXPECT_EQ(r.euler, 2);
  EXPECT_EQ(r.genus, 0);
  EXPECT_TRUE(r.oriented);
  EXPECT_DOUBLE_EQ(r.volume, 6.0);
  EXPECT_DOUBLE_EQ(r.area, 22.0);
  EXPECT_EQ(r.bbox.min, (Vec3{0, 0, 0}));
  EXPECT_EQ(r.bbox.max, (Vec3{1, 2, 3}));
  // The divergence theorem does not care where the box is.
  const DiagnosisReport moved = diagnose(make_box({10, -20, 30}, {11, -18, 33}));
  EXPECT_NEAR(moved.volume, 6.0, 1e-9);
  ASSERT_EQ(r.component_reports.size(), 1u);
  EXPECT_DOUBLE_EQ(r.component_reports[0].volume, 6.0);
  EXPECT_EQ(r.component_reports[0].vertices, 8u);
  EXPECT_TRUE(r.component_reports[0].closed);
}

TEST(Diagnose, InsideOutBoxHasNegativeVolume) {
  Mesh mesh = make_box({0, 0, 0}, {1, 2, 3});
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    std::swap(mesh.indices[3 * t + 1], mesh.indices[3 * t + 2]);
  }
  const DiagnosisReport r = diagnose(mesh);
  EXPECT_DOUBLE_EQ(r.volume, -6.0);
  EXPECT_TRUE(r.oriented);  // consistently inside out is still consistent
}

TEST(Diagnose, OpenCylinderHasTwoLoops) {
  const Mesh mesh = make_open_cylinder(1.0f, 2.0f, 16, 4);
  const DiagnosisReport r = diagnose(mesh);
  expect_consistent(mesh, r);
  EXPECT_EQ(r.vertices, 80u);
  EXPECT_EQ(r.triangles, 128u);
  EXPECT_EQ(r.boundary_edges, 32u);
  EXPECT_EQ(r.boundary_loops, 2u);
  EXPECT_EQ(r.euler, 0);
  EXPECT_EQ(r.genus, 0);
  EXPECT_EQ(r.nonmanifold_vertices, 0u);
  EXPECT_EQ(r.inconsistent_edges, 0u);
  EXPECT_FALSE(r.closed);
  EXPECT_FALSE(r.oriented);
}

TEST(Diagnose, TorusHasGenusOne) {
  const Mesh mesh = make_torus(2.0f, 0.5f, 24, 12);
  const DiagnosisReport r = diagnose(mesh);
  expect_consistent(mesh, r);
  EXPECT_EQ(r.vertices, 288u);
  EXPECT_EQ(r.triangles, 576u);
  EXPECT_EQ(r.edges, 864u);
  EXPECT_EQ(r.euler, 0);
  EXPECT_EQ(r.genus, 1);
  EXPECT_TRUE(r.oriented);
  // 2 pi^2 R r^2 = 9.87 for the smooth torus; the 24 x 12 polygonal one has 9.32 (a 12-gon holds
  // 95.5% of its circle's area, and the inner side of the 24-gon ring is shorter).
  const double volume = 2 * kPi * kPi * 2.0 * 0.25;
  EXPECT_LT(r.volume, volume);
  EXPECT_GT(r.volume, 0.93 * volume);
}

TEST(Diagnose, BookHasOneNonManifoldEdge) {
  const Mesh mesh = make_nonmanifold_book();
  const DiagnosisReport r = diagnose(mesh);
  expect_consistent(mesh, r);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.edges, 13u);  // the spine, 3 diagonals, 9 page edges
  EXPECT_EQ(r.nonmanifold_edges, 1u);
  EXPECT_EQ(r.nonmanifold_vertices, 2u);  // the spine's ends
  EXPECT_EQ(r.boundary_edges, 9u);
  EXPECT_EQ(r.euler, 1);
  EXPECT_EQ(r.genus, -1);
  EXPECT_FALSE(r.closed);
  // Each page's boundary is a chain from one spine end to the other. At each end the three chain
  // ends are joined two by two in fan order: pages 0 and 1 make a closed walk, page 2 stays open.
  EXPECT_EQ(r.boundary_loops, 2u);
}

TEST(Diagnose, BowTieHasOneNonManifoldVertex) {
  const Mesh mesh = make_bowtie_tetrahedra();
  const DiagnosisReport r = diagnose(mesh);
  expect_consistent(mesh, r);
  EXPECT_EQ(r.components, 1u);  // joined through the shared vertex
  EXPECT_EQ(r.nonmanifold_vertices, 1u);
  EXPECT_EQ(r.nonmanifold_edges, 0u);
  EXPECT_EQ(r.boundary_edges, 0u);
  EXPECT_EQ(r.edges, 12u);
  EXPECT_EQ(r.euler, 3);  // 7 - 12 + 8: two spheres glued at a point
  EXPECT_EQ(r.genus, -1);
  EXPECT_TRUE(r.closed);
  EXPECT_TRUE(r.oriented);
  EXPECT_NEAR(r.volume, 2.0 / 6.0, 1e-12);
}

TEST(Diagnose, OneFlippedTriangleGivesThreeInconsistentEdges) {
  Mesh mesh = make_icosphere(1, 1.0f);
  std::swap(mesh.indices[1], mesh.indices[2]);
  const DiagnosisReport r = diagnose(mesh);
  expect_consistent(mesh, r);
  EXPECT_EQ(r.inconsistent_edges, 3u);
  EXPECT_TRUE(r.closed);
  EXPECT_FALSE(r.oriented);
  EXPECT_EQ(r.genus, -1);
  EXPECT_EQ(r.nonmanifold_vertices, 0u);
  EXPECT_EQ(r.euler, 2);
  ASSERT_EQ(r.component_reports.size(), 1u);
  EXPECT_EQ(r.component_reports[0].inconsistent_edges, 3u);
}

TEST(Diagnose, ComponentsAreSortedLargestFirst) {
  const Mesh sphere = make_icosphere(1, 1.0f);      // 80 triangles
  const Mesh box = make_box({3, 3, 3}, {4, 4, 4});  // 12 triangles
  Mesh mesh;
  append(mesh, box);  // the smaller first in triangle order
  append(mesh, sphere);
  const DiagnosisReport r = diagnose(mesh);
  expect_consistent(mesh, r);
  ASSERT_EQ(r.components, 2u);
  EXPECT_EQ(r.component_reports[0].triangles, 80u);
  EXPECT_EQ(r.component_reports[0].vertices, 42u);
  EXPECT_EQ(r.component_reports[1].triangles, 12u);
  EXPECT_EQ(r.component_reports[1].vertices, 8u);
  EXPECT_DOUBLE_EQ(r.component_reports[1].volume, 1.0);
  EXPECT_EQ(r.component_reports[1].bbox.min, (Vec3{3, 3, 3}));
  for (size_t t = 0; t < 12; ++t) EXPECT_EQ(r.triangle_component[t], 1u);
  for (size_t t = 12; t < 92; ++t) EXPECT_EQ(r.triangle_component[t], 0u);
  EXPECT_EQ(r.genus, 0);
  EXPECT_EQ(r.euler, 4);
  EXPECT_NEAR(r.volume, r.component_reports[0].volume + 1.0, 1e-9);

  // Ties keep the order of their first triangles.
  Mesh twins;
  append(twins, make_box({0, 0, 0}, {1, 1, 1}));
  append(twins, make_box({5, 0, 0}, {7, 1, 1}));
  const DiagnosisReport t = diagnose(twins);
  ASSERT_EQ(t.components, 2u);
  EXPECT_EQ(t.triangle_component[0], 0u);
  EXPECT_EQ(t.triangle_component[12], 1u);
  EXPECT_DOUBLE_EQ(t.component_reports[1].volume, 2.0);
}

TEST(Diagnose, ComponentsJoinThroughVerticesNotOnlyEdges) {
  // Two triangles that share one vertex: one component, two boundary loops (a figure of eight).
  const Mesh mesh =
      mesh_of({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}}, {0, 1, 2, 0, 3, 4});
  const DiagnosisReport r = diagnose(mesh);
  expect_consistent(mesh, r);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.boundary_edges, 6u);
  EXPECT_EQ(r.boundary_loops, 2u);
  EXPECT_EQ(r.nonmanifold_vertices, 1u);
  EXPECT_EQ(r.nonmanifold_edges, 0u);
  EXPECT_EQ(r.euler, 1);
  EXPECT_EQ(r.genus, -1);
  EXPECT_DOUBLE_EQ(r.area, 1.0);
}

TEST(Diagnose, FigureOfEightBoundaryIsTwoLoops) {
  // Two open strips (two triangles each, a unit square in the XY plane and one in the YZ plane)
  // that touch at the single vertex 0: the boundary passes through vertex 0 twice.
  //   3---2                      the first square: 0 1 2 3 (z = 0)
  //   |   |                      the second: 0 4 5 6 (x = 0, below z = 0)
  //   0---1
  const Mesh mesh =
      mesh_of({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, -1}, {0, -1, -1}, {0, -1, 0}},
              {0, 1, 2, 0, 2, 3, 0, 4, 5, 0, 5, 6});
  const DiagnosisReport r = diagnose(mesh);
  expect_consistent(mesh, r);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.boundary_edges, 8u);
  EXPECT_EQ(r.boundary_loops, 2u);
  EXPECT_EQ(r.nonmanifold_vertices, 1u);
  EXPECT_EQ(r.inconsistent_edges, 0u);
  EXPECT_EQ(r.genus, -1);
  ASSERT_EQ(r.component_reports.size(), 1u);
  EXPECT_EQ(r.component_reports[0].boundary_loops, 2u);
}

TEST(Diagnose, AnnulusLoopsAreSeparate) {
  // A square frame with a square hole: 8 vertices, 8 triangles, an outer and an inner loop.
  //   7-------6
  //   | 3---2 |
  //   | |   | |
  //   | 0---1 |
  //   4-------5
  const Mesh mesh = mesh_of(
      {{1, 1, 0}, {2, 1, 0}, {2, 2, 0}, {1, 2, 0}, {0, 0, 0}, {3, 0, 0}, {3, 3, 0}, {0, 3, 0}},
      {4, 5, 1, 4, 1, 0, 5, 6, 2, 5, 2, 1, 6, 7, 3, 6, 3, 2, 7, 4, 0, 7, 0, 3});
  const DiagnosisReport r = diagnose(mesh);
  expect_consistent(mesh, r);
  EXPECT_EQ(r.boundary_edges, 8u);
  EXPECT_EQ(r.boundary_loops, 2u);
  EXPECT_EQ(r.euler, 0);
  EXPECT_EQ(r.genus, 0);
  EXPECT_EQ(r.inconsistent_edges, 0u);
  EXPECT_DOUBLE_EQ(r.area, 8.0);
}

TEST(Diagnose, EmptyMesh) {
  const Mesh mesh;
  const DiagnosisReport r = diagnose(mesh);
  expect_consistent(mesh, r);
  EXPECT_EQ(r.vertices, 0u);
  EXPECT_EQ(r.triangles, 0u);
  EXPECT_EQ(r.components, 0u);
  EXPECT_EQ(r.edges, 0u);
  EXPECT_EQ(r.euler, 0);
  EXPECT_EQ(r.genus, 0);
  EXPECT_FALSE(r.closed);  // no surface bounds nothing
  EXPECT_FALSE(r.oriented);
  EXPECT_TRUE(r.bbox.empty);
  EXPECT_EQ(r.area, 0.0);
  EXPECT_EQ(r.volume, 0.0);
}

TEST(Diagnose, PointsWithoutTriangles) {
  const Mesh mesh = mesh_of({{0, 0, 0}, {1, 2, 3}}, {});
  const DiagnosisReport r = diagnose(mesh);
  expect_consistent(mesh, r);
  EXPECT_EQ(r.unreferenced_vertices, 2u);
  EXPECT_EQ(r.euler, 2);
  EXPECT_EQ(r.components, 0u);
  EXPECT_FALSE(r.bbox.empty);  // bounding_box() of a mesh without indices spans its positions
  EXPECT_EQ(r.bbox.max, (Vec3{1, 2, 3}));
}

TEST(Diagnose, UnreferencedVerticesCountInEulerOnly) {
  Mesh mesh = make_box({0, 0, 0}, {1, 1, 1});
  mesh.positions.push_back({50, 50, 50});
  mesh.positions.push_back({60, 60, 60});
  mesh.positions.push_back({-9, -9, -9});
  const DiagnosisReport r = diagnose(mesh);
  expect_consistent(mesh, r);
  EXPECT_EQ(r.vertices, 11u);
  EXPECT_EQ(r.unreferenced_vertices, 3u);
  EXPECT_EQ(r.euler, 5);  // 2 + 3 isolated points
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.component_reports[0].vertices, 8u);
  EXPECT_EQ(r.component_reports[0].euler, 2);
  EXPECT_EQ(r.genus, 0);
  EXPECT_TRUE(r.oriented);
  EXPECT_EQ(r.bbox.max, (Vec3{1, 1, 1}));  // only referenced positions
}

TEST(Diagnose, RepeatedIndexMakesNoZeroLengthEdge) {
  // (0, 0, 1) uses {0, 1} twice, once each way, and {0, 0} not at all.
  const Mesh mesh = mesh_of({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {0, 0, 1});
  const DiagnosisReport r = diagnose(mesh);
  expect_consistent(mesh, r);
  EXPECT_EQ(r.degenerate_triangles, 1u);
  EXPECT_EQ(r.edges, 1u);
  EXPECT_EQ(r.boundary_edges, 0u);
  EXPECT_EQ(r.nonmanifold_edges, 0u);
  EXPECT_EQ(r.inconsistent_edges, 0u);
  EXPECT_EQ(r.nonmanifold_vertices, 0u);  // the two corners at vertex 0 are one
  EXPECT_EQ(r.unreferenced_vertices, 1u);
  EXPECT_EQ(r.euler, 3);  // 3 - 1 + 1
  EXPECT_EQ(r.area, 0.0);

  const Mesh point = mesh_of({{0, 0, 0}}, {0, 0, 0});
  const DiagnosisReport p = diagnose(point);
  expect_consistent(point, p);
  EXPECT_EQ(p.edges, 0u);
  EXPECT_EQ(p.nonmanifold_vertices, 0u);
  EXPECT_EQ(p.euler, 2);
}

TEST(Diagnose, DegenerateCategoryCounts) {
  // The fixture: a unit box plus (0, 0, 1) and a zero-area (0, mid, 1) on the box edge 0-1.
  const auto categories = test::mesh_categories();
  auto it = std::find_if(categories.begin(), categories.end(),
                         [](const test::NamedMesh& m) { return m.category == "degenerate"; });
  ASSERT_NE(it, categories.end());
  const DiagnosisReport r = diagnose(it->mesh);
  EXPECT_EQ(r.degenerate_triangles, 2u);
  EXPECT_EQ(r.vertices, 9u);
  EXPECT_EQ(r.edges, 20u);             // 18 box edges, {0, mid}, {mid, 1}
  EXPECT_EQ(r.nonmanifold_edges, 1u);  // {0, 1}: 2 box triangles, 2 from (0, 0, 1), 1 more
  EXPECT_EQ(r.boundary_edges, 2u);
  EXPECT_EQ(r.euler, 3);  // 9 - 20 + 14
  EXPECT_DOUBLE_EQ(r.volume, 1.0);
}

TEST(Diagnose, DuplicateTriangleMakesNonManifoldEdges) {
  Mesh mesh = make_box({0, 0, 0}, {1, 1, 1});
  mesh.indices.insert(mesh.indices.end(), mesh.indices.begin(), mesh.indices.begin() + 3);
  const DiagnosisReport r = diagnose(mesh);
  expect_consistent(mesh, r);
  EXPECT_EQ(r.nonmanifold_edges, 3u);
  EXPECT_EQ(r.nonmanifold_vertices, 3u);
  EXPECT_FALSE(r.closed);
}

TEST(Diagnose, ResultDoesNotDependOnTriangleOrder) {
  Mesh mesh = make_torus(3.0f, 1.0f, 10, 6);
  append(mesh, make_nonmanifold_book());
  append(mesh, make_open_cylinder(1.0f, 1.0f, 8, 2));
  const DiagnosisReport a = diagnose(mesh);
  // Reverse the triangle order and rotate each triangle's corners.
  Mesh shuffled = mesh;
  const size_t n = mesh.triangle_count();
  for (size_t t = 0; t < n; ++t) {
    const size_t from = n - 1 - t;
    shuffled.indices[3 * t] = mesh.indices[3 * from + 1];
    shuffled.indices[3 * t + 1] = mesh.indices[3 * from + 2];
    shuffled.indices[3 * t + 2] = mesh.indices[3 * from];
  }
  const DiagnosisReport b = diagnose(shuffled);
  EXPECT_EQ(a.components, b.components);
  EXPECT_EQ(a.edges, b.edges);
  EXPECT_EQ(a.boundary_edges, b.boundary_edges);
  EXPECT_EQ(a.boundary_loops, b.boundary_loops);
  EXPECT_EQ(a.nonmanifold_edges, b.nonmanifold_edges);
  EXPECT_EQ(a.nonmanifold_vertices, b.nonmanifold_vertices);
  EXPECT_EQ(a.euler, b.euler);
  EXPECT_EQ(a.genus, b.genus);
  EXPECT_NEAR(a.volume, b.volume, 1e-9);
  ASSERT_EQ(a.components, 3u);
  for (size_t c = 0; c < 3; ++c) {
    EXPECT_EQ(a.component_reports[c].triangles, b.component_reports[c].triangles);
    EXPECT_EQ(a.component_reports[c].genus, b.component_reports[c].genus);
  }
  EXPECT_EQ(a.component_reports[0].genus, 1);   // torus, 120 triangles
  EXPECT_EQ(a.component_reports[1].genus, 0);   // cylinder, 32 triangles
  EXPECT_EQ(a.component_reports[2].genus, -1);  // book, 6 triangles
  EXPECT_EQ(a.genus, -1);
}

TEST(Diagnose, LargeMesh) {
  // 327,680 triangles: the bucketed edge pass must agree with the closed-form counts.
  const Mesh mesh = make_icosphere(7, 1.0f);
  const DiagnosisReport r = diagnose(mesh);
  EXPECT_EQ(r.triangles, 327680u);
  EXPECT_EQ(r.vertices, 163842u);
  EXPECT_EQ(r.edges, 491520u);
  EXPECT_EQ(r.genus, 0);
  EXPECT_TRUE(r.oriented);
}

// The agreement of every real file with ../shared/data/STATS.csv is tests/real_data_test.cpp's.

}  // namespace diagnose_test
}  // namespace
}  // namespace osteon
