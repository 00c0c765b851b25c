// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>

#include "fixtures.hpp"
#include "osteon/io.hpp"
#include "support/phantom.hpp"

namespace osteon {
namespace {
namespace io_stl_test {

// A binary STL of `mesh`'s triangles with `header` (padded to 80 bytes).
std::string binary_stl(const Mesh& mesh, const std::string& header = "osteon test") {
  std::string out(80, '\0');
  std::memcpy(out.data(), header.data(), std::min<size_t>(header.size(), 80));
  uint32_t count = static_cast<uint32_t>(mesh.triangle_count());
  out.append(reinterpret_cast<const char*>(&count), 4);
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    float record[12] = {};
    for (int k = 0; k < 3; ++k) {
      const Vec3& p = mesh.positions[mesh.indices[3 * t + k]];
      record[3 + 3 * k] = p.x;
      record[4 + 3 * k] = p.y;
      record[5 + 3 * k] = p.z;
    }
    out.append(reinterpret_cast<const char*>(record), sizeof(record));
    out.append(2, '\0');
  }
  return out;
}

Mesh tetrahedron() {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.indices = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  return m;
}

const char* kAsciiTetra =
    "solid tetra\n"
    " facet normal 0 0 -1\n  outer loop\n   vertex 0 0 0\n   vertex 0 1 0\n   vertex 1 0 0\n"
    "  endloop\n endfacet\n"
    " facet normal 0 -1 0\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n   vertex 0 0 1\n"
    "  endloop\n endfacet\n"
    " facet normal -1 0 0\n  outer loop\n   vertex 0 0 0\n   vertex 0 0 1\n   vertex 0 1 0\n"
    "  endloop\n endfacet\n"
    " facet normal 1 1 1\n  outer loop\n   vertex 1 0 0\n   vertex 0 1 0\n   vertex 0 0 1\n"
    "  endloop\n endfacet\n"
    "endsolid tetra\n";

TEST(IoStl, BinaryWeldsToSharedVertices) {
  Mesh tet = tetrahedron();
  Scene scene = test::parse_or_fail(binary_stl(tet), "tet.stl");
  ASSERT_EQ(scene.parts.size(), 1u);
  const Mesh& m = scene.parts[0];
  EXPECT_EQ(m.name, "tet");
  EXPECT_EQ(m.source, "tet.stl");
  EXPECT_EQ(m.stored_vertices, 12u);
  EXPECT_EQ(m.vertex_count(), 4u);
  EXPECT_EQ(m.triangle_count(), 4u);
  EXPECT_EQ(test::canonical_triangles(m), test::canonical_triangles(tet));
}

TEST(IoStl, WithoutWeldKeepsTheSoup) {
  ReadOptions options;
  options.weld = false;
  Scene scene = test::parse_or_fail(binary_stl(tetrahedron()), "tet.stl", options);
  ASSERT_EQ(scene.parts.size(), 1u);
  EXPECT_EQ(scene.parts[0].vertex_count(), 12u);
  EXPECT_EQ(scene.parts[0].indices[5], 5u);
}

TEST(IoStl, AsciiLookingHeaderDoesNotFoolTheBinaryReader) {
  // The header begins "solid" and even says "facet": the size 84 + 50 * n still decides.
  std::string bytes = binary_stl(tetrahedron(), "solid facet endsolid exported by CAD");
  Scene scene = test::parse_or_fail(bytes, "cad.stl");
  ASSERT_EQ(scene.parts.size(), 1u);
  EXPECT_EQ(scene.parts[0].triangle_count(), 4u);
}

TEST(IoStl, AsciiReadsAndWelds) {
  Scene scene = test::parse_or_fail(kAsciiTetra, "tet.stl");
  ASSERT_EQ(scene.parts.size(), 1u);
  EXPECT_EQ(scene.parts[0].vertex_count(), 4u);
  EXPECT_EQ(scene.parts[0].stored_vertices, 12u);
  EXPECT_EQ(test::canonical_triangles(scene.parts[0]), test::canonical_triangles(tetrahedron()));
}

TEST(IoStl, AsciiWithSeveralSolidsGivesSeveralParts) {
  std::string two = std::string(kAsciiTetra) + kAsciiTetra;
  two.replace(two.rfind("solid tetra\n facet"), 11, "solid other");
  Scene scene = test::parse_or_fail(two, "two.stl");
  ASSERT_EQ(scene.parts.size(), 2u);
  EXPECT_EQ(scene.parts[0].name, "two/tetra");
  EXPECT_EQ(scene.parts[1].name, "two/other");
}

TEST(IoStl, AsciiAcceptsCrlfTabsExponentsAndSigns) {
  std::string text =
      "solid x\r\n\tfacet normal 0 0 0\r\n\t\touter loop\r\n\t\t\tvertex +1.5e+0 -0 2E-1\r\n"
      "\t\t\tvertex 1 1 1\r\n\t\t\tvertex 0 1 0\r\n\t\tendloop\r\n\tendfacet\r\nendsolid x\r\n";
  Scene scene = test::parse_or_fail(text, "x.stl");
  ASSERT_EQ(scene.parts.size(), 1u);
  EXPECT_EQ(scene.parts[0].positions[0], (Vec3{1.5f, 0.0f, 0.2f}));
}

TEST(IoStl, TruncatedBinaryFailsAtEveryCut) {
  std::string bytes = binary_stl(tetrahedron());
  for (size_t cut = 0; cut < bytes.size(); ++cut) {
    std::string error = test::parse_error(bytes.substr(0, cut), "cut.stl");
    EXPECT_FALSE(error.empty()) << "cut at " << cut;
    if (!error.empty()) {
      EXPECT_EQ(error.rfind("cut.stl: ", 0), 0u) << error;
    }
  }
}

TEST(IoStl, TruncatedAsciiFailsAtEveryCut) {
  std::string text = kAsciiTetra;
  size_t end = text.find("endsolid");
  for (size_t cut = 1; cut < end; cut += 3) {
    EXPECT_FALSE(test::parse_error(text.substr(0, cut), "cut.stl").empty()) << "cut at " << cut;
  }
}

TEST(IoStl, HugeDeclaredCountIsRejectedBeforeAllocating) {
  std::string bytes = binary_stl(tetrahedron());
  uint32_t huge = 0xffffffffu;
  std::memcpy(bytes.data() + 80, &huge, 4);
  std::string error = test::parse_error(bytes, "huge.stl");
  EXPECT_NE(error.find("4294967295 triangles"), std::string::npos) << error;
  EXPECT_NE(error.find("(byte 80)"), std::string::npos) << error;
}

TEST(IoStl, NonFiniteCoordinatesAreRejectedWithTheirPosition) {
  for (float bad :
       {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
    Mesh tet = tetrahedron();
    tet.positions[3].y = bad;  // vertex 3 appears first in triangle 1, corner 2
    std::string error = test::parse_error(binary_stl(tet), "nan.stl");
    EXPECT_NE(error.find("vertex 5 has a NaN or infinite coordinate"), std::string::npos) << error;
    EXPECT_NE(error.find("byte " + std::to_string(84 + 50 + 12 + 24)), std::string::npos) << error;
  }
  std::string text = kAsciiTetra;
  text.replace(text.find("vertex 0 1 0"), 12, "vertex 0 nan 0");
  EXPECT_NE(test::parse_error(text, "nan.stl").find("line 5"), std::string::npos);
}

TEST(IoStl, GarbageAndEmptyFilesGiveClearErrors) {
  EXPECT_NE(test::parse_error("", "empty.stl").find("empty.stl: file is empty"), std::string::npos);
  EXPECT_NE(test::parse_error("hello", "short.stl").find("too short"), std::string::npos);
  std::string text = kAsciiTetra;
  text.replace(text.find("outer loop"), 10, "outer lööp");
  std::string error = test::parse_error(text, "bad.stl");
  EXPECT_NE(error.find("expected 'loop'"), std::string::npos) << error;
  EXPECT_NE(error.find("line 3"), std::string::npos) << error;
}

TEST(IoStl, FileStreamingMatchesMemoryParsingAcrossChunks) {
  // Over 1 MiB of records, so the streaming reader crosses several chunk boundaries.
  Mesh sphere = make_icosphere(6, 10.0f);  // 81920 triangles, 4 MB
  std::string bytes = binary_stl(sphere);
  ASSERT_GT(bytes.size(), 1u << 20);
  std::string path = test::scratch_dir() + "/sphere.stl";
  test::write_bytes(path, bytes);
  Result<Scene> from_file = read_path(path);
  ASSERT_TRUE(from_file.ok()) << from_file.status().message();
  Scene from_memory = test::parse_or_fail(bytes, path);
  ASSERT_EQ(from_file->parts.size(), 1u);
  EXPECT_EQ(from_file->parts[0].positions, from_memory.parts[0].positions);
  EXPECT_EQ(from_file->parts[0].indices, from_memory.parts[0].indices);
  EXPECT_EQ(from_file->parts[0].vertex_count(), sphere.vertex_count());

  // The same file cut short names the missing bytes.
  test::write_bytes(path, bytes.substr(0, bytes.size() - 7));
  Result<Scene> cut = read_path(path);
  ASSERT_FALSE(cut.ok());
  EXPECT_NE(cut.status().message().find("but the file has 4096077 bytes"), std::string::npos)
      << cut.status().message();
}

TEST(IoStl, RealMyoSimBonesMatchStats) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  Result<Scene> scene = read_path(data + "/MyoHub__myo_sim/meshes/1mc.stl");
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  EXPECT_EQ(scene->parts[0].triangle_count(), 5744u);
  EXPECT_EQ(scene->parts[0].vertex_count(), 2874u);
  EXPECT_EQ(scene->parts[0].stored_vertices, 17232u);
  EXPECT_EQ(scene->parts[0].unit, Unit::kMetre);
  EXPECT_EQ(scene->parts[0].unit_source, UnitSource::kGuessed);
}

}  // namespace io_stl_test
}  // namespace
}  // namespace osteon
