// SPDX-License-Identifier: Apache-2.0
#include "osteon/mesh.hpp"

#include <gtest/gtest.h>

namespace osteon {
namespace {
namespace mesh_test {

TEST(Mesh, UnitNamesRoundTrip) {
  for (Unit u : {Unit::kMillimetre, Unit::kCentimetre, Unit::kMetre, Unit::kInch}) {
    Unit parsed = Unit::kUnknown;
    ASSERT_TRUE(parse_unit(unit_name(u), &parsed));
    EXPECT_EQ(parsed, u);
  }
  Unit u = Unit::kUnknown;
  EXPECT_TRUE(parse_unit("Millimetres", &u));
  EXPECT_EQ(u, Unit::kMillimetre);
  EXPECT_FALSE(parse_unit("furlong", &u));
}

TEST(Mesh, GuessUnitFromBoneSize) {
  Scene scene;
  Mesh phalanx;
  phalanx.positions = {{0, 0, 0}, {0.016f, 0, 0}, {0, 0.008f, 0}};
  phalanx.indices = {0, 1, 2};
  scene.parts.push_back(phalanx);
  EXPECT_EQ(guess_unit(scene), Unit::kMetre);
  for (Vec3& p : scene.parts[0].positions) p = {p.x * 1000, p.y * 1000, p.z * 1000};
  EXPECT_EQ(guess_unit(scene), Unit::kMillimetre);
  EXPECT_EQ(guess_unit(Scene{}), Unit::kUnknown);
}

TEST(Mesh, BoundingBoxCoversReferencedVertices) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 2, 3}, {-1, 0, 5}, {100, 100, 100}};
  m.indices = {0, 1, 2};
  Aabb box = bounding_box(m);
  EXPECT_FALSE(box.empty);
  EXPECT_EQ(box.min, (Vec3{-1, 0, 0}));
  EXPECT_EQ(box.max, (Vec3{1, 2, 5}));
  m.indices.clear();
  EXPECT_EQ(bounding_box(m).max, (Vec3{100, 100, 100}));
  EXPECT_TRUE(bounding_box(Mesh{}).empty);
}

TEST(Mesh, ExpandGrowsBoxesByPointsAndBoxes) {
  Aabb box;
  expand(box, Aabb{});
  EXPECT_TRUE(box.empty);
  expand(box, Vec3{1, 2, 3});
  EXPECT_FALSE(box.empty);
  EXPECT_EQ(box.min, (Vec3{1, 2, 3}));
  Aabb other;
  expand(other, Vec3{-1, 5, 0});
  expand(box, other);
  EXPECT_EQ(box.min, (Vec3{-1, 2, 0}));
  EXPECT_EQ(box.max, (Vec3{1, 5, 3}));
}

}  // namespace mesh_test
}  // namespace
}  // namespace osteon
