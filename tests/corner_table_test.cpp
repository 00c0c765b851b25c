// SPDX-License-Identifier: Apache-2.0
#include "codec/corner_table.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <random>
#include <vector>

#include "fixtures.hpp"
#include "osteon/mesh.hpp"
#include "support/phantom.hpp"

// The corner table and the cut into a closed manifold: pairing only two-sided edges, one new
// vertex per extra fan, one dummy vertex per boundary loop, and nothing else changed.

namespace osteon::detail {
namespace {
namespace corner_table_test {

// The input triangles recovered from a ClosedManifold: faces 0..T-1 with copies mapped back.
std::vector<uint32_t> recovered_indices(const ClosedManifold& m) {
  std::vector<uint32_t> out;
  for (uint32_t c = 0; c < 3 * m.input_triangles; ++c) {
    VertexIndex v = m.table.v(CornerIndex(c));
    EXPECT_FALSE(m.is_dummy(v));
    if (m.is_copy(v)) v = m.copy_of[v.value - m.input_vertices];
    out.push_back(v.value);
  }
  return out;
}

void expect_closes(const std::vector<uint32_t>& indices, uint32_t vertex_count,
                   uint32_t expected_copies, uint32_t expected_loops,
                   uint32_t expected_dummy_faces) {
  ClosedManifold m = close_to_manifold(indices, vertex_count);
  EXPECT_TRUE(is_closed_manifold(m.table));
  EXPECT_EQ(m.input_triangles, indices.size() / 3);
  EXPECT_EQ(m.copy_of.size(), expected_copies);
  EXPECT_EQ(m.table.vertex_count - m.first_dummy, expected_loops);
  EXPECT_EQ(m.dummy_faces, expected_dummy_faces);
  EXPECT_EQ(m.table.face_count(), m.input_triangles + m.dummy_faces);
  EXPECT_EQ(recovered_indices(m), indices);
}

TEST(CornerTable, NextPrevFace) {
  EXPECT_EQ(next(CornerIndex(0)), CornerIndex(1));
  EXPECT_EQ(next(CornerIndex(2)), CornerIndex(0));
  EXPECT_EQ(prev(CornerIndex(3)), CornerIndex(5));
  EXPECT_EQ(prev(CornerIndex(4)), CornerIndex(3));
  EXPECT_EQ(face_of(CornerIndex(5)), FaceIndex(1));
  EXPECT_EQ(first_corner(FaceIndex(2)), CornerIndex(6));
  EXPECT_FALSE(kNoCorner.valid());
}

TEST(CornerTable, PairsOnlyTwoSidedEdges) {
  // Two triangles sharing 0-1 consistently, a third on the same edge the same way as the first.
  CornerTable t = pair_half_edges({0, 1, 2, 1, 0, 3}, 4);
  EXPECT_EQ(t.o(CornerIndex(2)), CornerIndex(5));  // edge 0->1 opposite corner 2, 1->0 opposite 5
  EXPECT_EQ(t.o(CornerIndex(5)), CornerIndex(2));
  EXPECT_FALSE(t.o(CornerIndex(0)).valid());
  t = pair_half_edges({0, 1, 2, 1, 0, 3, 0, 1, 4}, 5);
  EXPECT_FALSE(t.o(CornerIndex(2)).valid());
  EXPECT_FALSE(t.o(CornerIndex(5)).valid());
  // Inconsistent orientation: both run 0 -> 1.
  t = pair_half_edges({0, 1, 2, 0, 1, 3}, 4);
  for (uint32_t c = 0; c < 6; ++c) EXPECT_FALSE(t.o(CornerIndex(c)).valid());
}

// The pairing rule by brute force: corner c's edge u -> w pairs with the corner of the one edge
// w -> u when each direction occurs exactly once.
std::vector<CornerIndex> paired_by_definition(const std::vector<uint32_t>& indices) {
  const uint32_t corners = static_cast<uint32_t>(indices.size());
  auto from = [&](uint32_t c) { return indices[next(CornerIndex(c)).value]; };
  auto to = [&](uint32_t c) { return indices[prev(CornerIndex(c)).value]; };
  std::vector<CornerIndex> out(corners, kNoCorner);
  for (uint32_t c = 0; c < corners; ++c) {
    uint32_t same = 0, reverse = 0, twin = 0;
    for (uint32_t d = 0; d < corners; ++d) {
      same += from(d) == from(c) && to(d) == to(c) ? 1 : 0;
      if (from(d) == to(c) && to(d) == from(c)) {
        ++reverse;
        twin = d;
      }
    }
    if (same == 1 && reverse == 1) out[c] = CornerIndex(twin);
  }
  return out;
}

TEST(CornerTable, PairsAsDefinedAtVerticesOfAnyDegree) {
  // A vertex keeps up to eight outgoing edges in fixed slots and the rest in an overflow list:
  // random triangles over few vertices give degrees far above eight, repeated and reversed
  // edges, and every mix of slots and overflow.
  std::mt19937 rng(7);
  for (uint32_t vertices : {4u, 6u, 9u, 16u, 40u}) {
    for (int trial = 0; trial < 20; ++trial) {
      std::vector<uint32_t> indices;
      const uint32_t triangles = 1 + rng() % 60;
      while (indices.size() < 3 * size_t{triangles}) {
        const uint32_t a = rng() % vertices, b = rng() % vertices, c = rng() % vertices;
        if (a == b || b == c || a == c) continue;
        indices.insert(indices.end(), {a, b, c});
      }
      const CornerTable t = pair_half_edges(indices, vertices);
      const std::vector<CornerIndex> expected = paired_by_definition(indices);
      for (uint32_t c = 0; c < indices.size(); ++c) {
        ASSERT_EQ(t.o(CornerIndex(c)), expected[c]) << "corner " << c << ", " << vertices << " vertices";
      }
    }
  }
  // A closed fan of 30 triangles: the apex and the base centre have degree 30.
  std::vector<uint32_t> cone;
  for (uint32_t i = 0; i < 30; ++i) {
    const uint32_t a = 2 + i, b = 2 + (i + 1) % 30;
    cone.insert(cone.end(), {0, a, b, 1, b, a});
  }
  expect_closes(cone, 32, 0, 0, 0);
}

TEST(CornerTable, SwingsWalkAroundAVertex) {
  Mesh m = make_icosphere(1);
  CornerTable t = pair_half_edges(m.indices, static_cast<uint32_t>(m.vertex_count()));
  t.vertex_count = static_cast<uint32_t>(m.vertex_count());
  ASSERT_TRUE(is_closed_manifold(t));
  for (uint32_t c = 0; c < t.corner_count(); ++c) {
    CornerIndex q = t.swing_out(CornerIndex(c));
    ASSERT_TRUE(q.valid());
    EXPECT_EQ(t.v(q), t.v(CornerIndex(c)));
    EXPECT_EQ(t.swing_in(q), CornerIndex(c));
  }
}

TEST(CornerTable, ClosedMeshIsUnchanged) {
  Mesh m = make_icosphere(2);
  expect_closes(m.indices, static_cast<uint32_t>(m.vertex_count()), 0, 0, 0);
}

TEST(CornerTable, SingleTriangleBecomesATetrahedron) {
  expect_closes({0, 1, 2}, 3, 0, 1, 3);
  ClosedManifold m = close_to_manifold({0, 1, 2}, 3);
  EXPECT_EQ(m.table.vertex_count, 4u);
}

TEST(CornerTable, OpenCylinderGetsTwoDummies) {
  Mesh m = make_open_cylinder(1.0f, 2.0f, 16, 4);
  expect_closes(m.indices, static_cast<uint32_t>(m.vertex_count()), 0, 2, 32);
}

TEST(CornerTable, BowtieVertexIsCopied) {
  Mesh m = make_bowtie_tetrahedra();
  expect_closes(m.indices, static_cast<uint32_t>(m.vertex_count()), 1, 0, 0);
}

TEST(CornerTable, BookEdgeIsCut) {
  // Three quads on one edge: that edge pairs nothing, its two vertices have three fans each.
  Mesh m = make_nonmanifold_book();
  ClosedManifold c = close_to_manifold(m.indices, static_cast<uint32_t>(m.vertex_count()));
  EXPECT_TRUE(is_closed_manifold(c.table));
  EXPECT_EQ(c.copy_of.size(), 4u);
  EXPECT_EQ(c.table.vertex_count - c.first_dummy, 3u);
  EXPECT_EQ(recovered_indices(c), m.indices);
}

TEST(CornerTable, InconsistentPairAndLoopOfTwo) {
  // 0->1 twice: nothing pairs; vertices 0 and 1 get a copy each; two loops of three.
  expect_closes({0, 1, 2, 0, 1, 3}, 4, 2, 2, 6);
  // Edge {0,1} with 0->1, 1->0 and 0->1 again, where the first two triangles' fans around 0 and
  // 1 are joined elsewhere: a boundary loop of length 2 (two dummy faces over the same pair).
  // A double-sided square (two fans joined at the rim) with a third triangle on the diagonal.
  std::vector<uint32_t> idx = {0, 1, 2, 0, 2, 3, 1, 0, 3, 1, 3, 2, 0, 1, 4};
  ClosedManifold m = close_to_manifold(idx, 5);
  EXPECT_TRUE(is_closed_manifold(m.table));
  EXPECT_EQ(recovered_indices(m), idx);
}

TEST(CornerTable, DuplicateFaceAndSoups) {
  Mesh box = make_box({0, 0, 0}, {1, 1, 1});
  std::vector<uint32_t> idx = box.indices;
  idx.insert(idx.end(), box.indices.begin(), box.indices.begin() + 3);
  ClosedManifold m = close_to_manifold(idx, 8);
  EXPECT_TRUE(is_closed_manifold(m.table));
  EXPECT_EQ(recovered_indices(m), idx);

  std::mt19937 rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    const uint32_t v = 4 + rng() % 12;
    const uint32_t t = 1 + rng() % 40;
    std::vector<uint32_t> soup;
    for (uint32_t i = 0; i < t; ++i) {
      uint32_t a = rng() % v, b = rng() % v, c = rng() % v;
      if (a == b || b == c || a == c) continue;
      soup.insert(soup.end(), {a, b, c});
    }
    ClosedManifold s = close_to_manifold(soup, v);  // unreferenced vertices are fine here
    std::vector<uint8_t> used(v, 0);
    for (uint32_t i : soup) used[i] = 1;
    // Unreferenced input vertices have no fan: compact them out of the check by counting.
    uint32_t unused = static_cast<uint32_t>(std::count(used.begin(), used.end(), 0));
    if (unused == 0) {
      EXPECT_TRUE(is_closed_manifold(s.table)) << "trial " << trial;
    }
    EXPECT_EQ(recovered_indices(s), soup);
  }
}

}  // namespace corner_table_test
}  // namespace
}  // namespace osteon::detail
