// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "fixtures.hpp"
#include "io_internal.hpp"
#include "osteon/io.hpp"

namespace osteon {
namespace {
namespace io_obj_test {

using detail::parse_obj;

Status parse(const std::string& text, Scene* scene) {
  return parse_obj(reinterpret_cast<const uint8_t*>(text.data()), text.size(), "t.obj", {}, scene);
}

Scene parse_scene(const std::string& text) {
  Scene scene;
  Status status = parse(text, &scene);
  EXPECT_TRUE(status.ok()) << status.message();
  return scene;
}

Mesh parse_one(const std::string& text) {
  Scene scene = parse_scene(text);
  if (scene.parts.size() != 1) {
    ADD_FAILURE() << "expected one part, got " << scene.parts.size();
    return {};
  }
  return std::move(scene.parts[0]);
}

std::string parse_message(const std::string& text) {
  Scene scene;
  return parse(text, &scene).message();
}

TEST(IoObj, TrianglesAndPolygonsWithExtraVertexValues) {
  Mesh mesh = parse_one(
      "# a square and a triangle\n"
      "v 0 0 0\n"
      "v 1 0 0 1.0\n"          // w, ignored
      "v 1 1 0 0.5 0.5 0.5\n"  // a colour, ignored
      "v 0 1 0\n"
      "v 2.5 -1e-2 +3\n"
      "f 1 2 3 4\n"
      "f 2 5 3\n");
  EXPECT_EQ(mesh.positions,
            (std::vector<Vec3>{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {2.5f, -1e-2f, 3}}));
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 1, 4, 2}));
  EXPECT_EQ(mesh.stored_vertices, 5u);
  EXPECT_TRUE(mesh.name.empty());
  EXPECT_TRUE(mesh.normals.empty());
}

TEST(IoObj, AllCornerFormsAndNegativeIndices) {
  std::string head =
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nvn 0 0 1\nvn 0 0 1\n";
  const char* faces[] = {
      "f 1 2 3\n",
      "f 1/1 2/2 3/3\n",
      "f 1//1 2//2 3//3\n",
      "f 1/1/1 2/2/2 3/3/3\n",
      "f -3 -2 -1\n",
      "f -3/-3/-3 -2/-2/-2 -1/-1/-1\n",
      "f 1/-3 -2//2 3/3/-1\n",
  };
  for (const char* face : faces) {
    Mesh mesh = parse_one(head + face);
    EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2})) << face;
    EXPECT_EQ(mesh.positions.size(), 3u) << face;
  }
  // Negative indices count back from the line they are on, not from the end of the file.
  Mesh mesh = parse_one("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 5 5 5\nf -4 -3 -1\n");
  EXPECT_EQ(mesh.positions, (std::vector<Vec3>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {5, 5, 5}}));
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 1, 3}));
}

TEST(IoObj, GroupsArePartsWithTheirOwnVertices) {
  Scene scene = parse_scene(
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 2 2 2\n"
      "f 1 2 3\n"  // before any group: the part with an empty name
      "g femur\n"
      "f 4 3 2\n"
      "o empty object\n"  // no faces: no part
      "usemtl bone\n"
      "g tibia left\n"
      "f 5 4 3\n"
      "g femur\n"  // femur again: its part grows
      "f 4 2 1\n");
  ASSERT_EQ(scene.parts.size(), 3u);
  EXPECT_EQ(scene.parts[0].name, "");
  EXPECT_EQ(scene.parts[0].indices, (std::vector<uint32_t>{0, 1, 2}));
  EXPECT_EQ(scene.parts[0].stored_vertices, 3u);

  const Mesh& femur = scene.parts[1];
  EXPECT_EQ(femur.name, "femur");
  // Positions in the order the part's faces first use them: 4 3 2, then 1.
  EXPECT_EQ(femur.positions, (std::vector<Vec3>{{1, 1, 0}, {0, 1, 0}, {1, 0, 0}, {0, 0, 0}}));
  EXPECT_EQ(femur.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
  EXPECT_EQ(femur.stored_vertices, 4u);

  const Mesh& tibia = scene.parts[2];
  EXPECT_EQ(tibia.name, "tibia left");
  EXPECT_EQ(tibia.positions, (std::vector<Vec3>{{2, 2, 2}, {1, 1, 0}, {0, 1, 0}}));
  EXPECT_EQ(tibia.indices, (std::vector<uint32_t>{0, 1, 2}));

  // The dispatcher names several parts "stem/name", an unnamed one by its index.
  ReadOptions options;
  options.weld = false;
  Scene named = test::parse_or_fail("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\ng a\nf 1 2 3\n",
                                    "bones/hand.obj", options);
  ASSERT_EQ(named.parts.size(), 2u);
  EXPECT_EQ(named.parts[0].name, "hand/0");
  EXPECT_EQ(named.parts[1].name, "hand/a");
  Scene single = test::parse_or_fail("o x\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "hand.obj");
  ASSERT_EQ(single.parts.size(), 1u);
  EXPECT_EQ(single.parts[0].name, "hand");
}

TEST(IoObj, NormalsOnlyWhenCompleteAndConsistent) {
  std::string head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0 0 1\nvn 0 0 1\nvn 1 0 0\n";
  // Every corner names a normal; position 1 gets normal 1 and normal 2, equal by value.
  Mesh kept = parse_one(head + "f 1//1 2//1 3//1\nf 2//2 4//3 3//2\n");
  EXPECT_EQ(kept.normals, (std::vector<Vec3>{{0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {1, 0, 0}}));
  // One corner without a normal: the part has none.
  EXPECT_TRUE(parse_one(head + "f 1//1 2//1 3//1\nf 2//2 4 3//2\n").normals.empty());
  // Position 2 gets two different normals: none.
  EXPECT_TRUE(parse_one(head + "f 1//1 2//1 3//1\nf 2//3 4//3 3//2\n").normals.empty());
  // A non-finite normal: none.
  EXPECT_TRUE(
      parse_one("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 inf\nf 1//1 2//1 3//1\n").normals.empty());
  // Per part: one group keeps its normals, the other has none.
  Scene scene = parse_scene(head + "g a\nf 1//1 2//1 3//1\ng b\nf 2 4 3\n");
  ASSERT_EQ(scene.parts.size(), 2u);
  EXPECT_EQ(scene.parts[0].normals.size(), 3u);
  EXPECT_TRUE(scene.parts[1].normals.empty());
}

TEST(IoObj, CommentsContinuationsCrLfAndUnknownKeywords) {
  Mesh reference = parse_one("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  const std::string variants[] = {
      "# header\n\nmtllib bones.mtl\nv 0 0 0\r\nv 1 0 0 # trailing comment\r\n\r\n"
      "v 0 1 0\r\nusemtl bone\ns 1\nl 1 2\np 1\nvp 0.5\ncstype bspline\n"
      "f 1 2 3 # face comment\r\n",
      "v 0 \\\n0 0\nv 1 0 0\nv 0 1 0\nf 1 \\\n 2 \\\n3\n",
      "\t v\t0 0 0\n  v 1 0 0\nv 0 1 0\n\tf  1\t2 3   \n",
      "\xEF\xBB\xBFv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3",  // a byte order mark, no final newline
      "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n",            // positive indices may name later vertices
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\nf 1 2 3\n",     // a 2-corner face gives no triangle
  };
  for (const std::string& text : variants) {
    Mesh mesh = parse_one(text);
    EXPECT_EQ(mesh.positions, reference.positions) << text;
    EXPECT_EQ(mesh.indices, reference.indices) << text;
  }
}

TEST(IoObj, BadFilesAreErrorsWithLines) {
  struct Case {
    std::string text;
    std::string expected;
  };
  std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  const Case cases[] = {
      {"", "t.obj: no triangles"},
      {"# nothing\nv 0 0 0\nv 1 0 0\nv 0 1 0\n", "t.obj: no triangles"},
      {"\x01\x02\xff\xfe garbage\n\x00\x01", "no triangles"},
      {tri + "f 1 2\n", "no triangles: all 1 faces have fewer than 3 corners"},
      {tri + "f 0 1 2\n", "vertex index 0 (OBJ indices start at 1) (line 4)"},
      {tri + "f 1 2 4\n", "vertex index 4 out of range (the file defines 3) (line 4)"},
      {tri + "f 1 2 3\nf 1 9 3\nf 1 2 7\n",
       "vertex index 9 out of range (the file defines 3) "
       "(line 5)"},
      {tri + "f -1 -2 -4\n", "relative vertex index -4 out of range (3 defined so far) (line 4)"},
      {tri + "f 1 2 -9223372036854775808\n", "relative vertex index"},
      {tri + "f 1 2 99999999999\n", "vertex index 99999999999 out of range"},
      {tri + "f 1 2 x\n", "bad vertex index 'x' (line 4)"},
      {tri + "f 1/1 2 3\n", "texture index 1 out of range (the file defines 0) (line 4)"},
      {tri + "f 1//1 2 3\n", "normal index 1 out of range (the file defines 0) (line 4)"},
      {tri + "f 1/2/3/4 2 3\n", "bad face corner '1/2/3/4' (line 4)"},
      {tri + "f /1 2 3\n", "bad face corner '/1'"},
      {"v 0 0\nv 1 0 0\n", "v needs three numbers (line 1)"},
      {"v 0 zero 0\n", "v: 'zero' is not a number (line 1)"},
      {"v 0 0 0\nv nan 0 0\n", "vertex 1 has a NaN or infinite coordinate (line 2)"},
      {"v 0 0 0\nv 0 -inf 0\n", "vertex 1 has a NaN or infinite coordinate"},
      {"v 0 0 0\nv 0 1e39 0\n", "vertex 1 has a NaN or infinite coordinate"},
      {"vn 0 0\n", "vn needs three numbers"},
  };
  for (const Case& c : cases) {
    std::string message = parse_message(c.text);
    EXPECT_NE(message.find(c.expected), std::string::npos)
        << "expected '" << c.expected << "' in '" << message << "'";
  }
  EXPECT_EQ(test::parse_error("", "empty.obj"), "empty.obj: file is empty (byte 0)");
}

TEST(IoObj, TruncatedAtEveryByteNeverCrashes) {
  std::string file =
      "# cube corner\r\nmtllib x.mtl\no part\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\n"
      "vn 0 0 1\ng a\nf 1/1/1 2/1/1 3/1/1\ng b\nf -4//-1 -3//-1 -1//-1 -2//1\n";
  ASSERT_EQ(parse_message(file), "");
  size_t failures = 0;
  for (size_t cut = 0; cut < file.size(); ++cut) {
    Scene scene;
    Status status = parse(file.substr(0, cut), &scene);
    if (!status.ok()) {
      ++failures;
      EXPECT_EQ(status.message().rfind("t.obj: ", 0), 0u) << status.message();
    } else {
      for (const Mesh& part : scene.parts) {
        for (uint32_t i : part.indices) EXPECT_LT(i, part.positions.size());
      }
    }
  }
  EXPECT_GT(failures, 0u);
}

}  // namespace io_obj_test
}  // namespace
}  // namespace osteon
