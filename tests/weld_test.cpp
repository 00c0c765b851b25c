// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include "fixtures.hpp"
#include "osteon/mesh.hpp"
#include "support/phantom.hpp"

namespace osteon {
namespace {
namespace weld_test {

// Turns an indexed mesh into the soup an STL stores: three fresh vertices per triangle.
Mesh to_soup(const Mesh& mesh) {
  Mesh soup;
  for (uint32_t i : mesh.indices) {
    soup.indices.push_back(static_cast<uint32_t>(soup.positions.size()));
    soup.positions.push_back(mesh.positions[i]);
  }
  return soup;
}

TEST(Weld, SoupOfEveryCategoryWeldsBackToTheSameTriangles) {
  for (const auto& [category, mesh] : test::mesh_categories()) {
    SCOPED_TRACE(category);
    Mesh soup = to_soup(mesh);
    WeldReport report = weld(soup);
    EXPECT_EQ(report.vertices_before, 3 * mesh.triangle_count());
    // Every category's generator shares vertices, so welding recovers exactly the referenced ones.
    Mesh expected = mesh;
    remove_unreferenced_vertices(expected);
    EXPECT_EQ(report.vertices_after, expected.vertex_count());
    EXPECT_EQ(test::canonical_triangles(soup), test::canonical_triangles(mesh));
  }
}

TEST(Weld, NegativeZeroEqualsPositiveZero) {
  Mesh m;
  m.positions = {{0.0f, 1, 2}, {-0.0f, 1, 2}, {1, 1, 1}};
  m.indices = {0, 1, 2};
  weld(m);
  EXPECT_EQ(m.vertex_count(), 2u);
  EXPECT_EQ(m.indices, (std::vector<uint32_t>{0, 0, 1}));
}

TEST(Weld, KeepsFirstOccurrenceOrderAndFirstNormal) {
  Mesh m;
  m.positions = {{1, 0, 0}, {2, 0, 0}, {1, 0, 0}, {3, 0, 0}};
  m.normals = {{0, 0, 1}, {0, 1, 0}, {1, 0, 0}, {0, 0, -1}};
  m.indices = {0, 1, 3, 2, 3, 1};
  weld(m);
  ASSERT_EQ(m.vertex_count(), 3u);
  EXPECT_EQ(m.positions[0], (Vec3{1, 0, 0}));
  EXPECT_EQ(m.positions[2], (Vec3{3, 0, 0}));
  EXPECT_EQ(m.normals[0], (Vec3{0, 0, 1}));
  EXPECT_EQ(m.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 1}));
}

TEST(Weld, UnreferencedVerticesStayUntilRemoved) {
  Mesh m;
  m.positions = {{9, 9, 9}, {0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.indices = {1, 2, 3};
  weld(m);
  EXPECT_EQ(m.vertex_count(), 4u);
  EXPECT_EQ(remove_unreferenced_vertices(m), 1u);
  EXPECT_EQ(m.positions[0], (Vec3{0, 0, 0}));
  EXPECT_EQ(m.indices, (std::vector<uint32_t>{0, 1, 2}));
}

TEST(Weld, ToleranceMergesNearbyButNotFarVertices) {
  Mesh m = to_soup(make_icosphere(2, 1.0f));
  // Jitter every corner by less than 1e-4: exact welding no longer finds them, tolerance does.
  for (size_t i = 0; i < m.positions.size(); ++i) {
    float d = 1e-5f * static_cast<float>(i % 7);
    m.positions[i].x += d;
  }
  Mesh exact = m;
  weld(exact);
  EXPECT_GT(exact.vertex_count(), 162u);
  weld(m, WeldOptions{1e-4f});
  EXPECT_EQ(m.vertex_count(), 162u);  // 10 * 4^2 + 2
  EXPECT_EQ(count_degenerate_triangles(m), 0u);
}

TEST(Weld, GrowsPastItsInitialTable) {
  Mesh m;
  for (int i = 0; i < 100000; ++i) m.positions.push_back({float(i), float(i % 3), 0});
  for (int i = 0; i < 100000; ++i) m.positions.push_back({float(i), float(i % 3), 0});
  for (uint32_t i = 0; i + 2 < 200000; i += 3) m.indices.insert(m.indices.end(), {i, i + 1, i + 2});
  weld(m);
  EXPECT_EQ(m.vertex_count(), 100000u);
}

TEST(Degenerate, RepeatedIndexAndZeroAreaAreFoundAndRemoved) {
  for (const auto& [category, mesh] : test::mesh_categories()) {
    SCOPED_TRACE(category);
    Mesh copy = mesh;
    size_t expected = category == "degenerate" ? 2 : 0;
    EXPECT_EQ(count_degenerate_triangles(copy), expected);
    size_t before = copy.triangle_count();
    EXPECT_EQ(remove_degenerate_triangles(copy), expected);
    EXPECT_EQ(copy.triangle_count(), before - expected);
    EXPECT_EQ(count_degenerate_triangles(copy), 0u);
  }
}

}  // namespace weld_test
}  // namespace
}  // namespace osteon
