// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "fixtures.hpp"
#include "io_internal.hpp"
#include "osteon/io.hpp"

namespace osteon {
namespace {
namespace io_off_test {

using detail::parse_off;

Status parse(const std::string& text, Scene* scene) {
  return parse_off(reinterpret_cast<const uint8_t*>(text.data()), text.size(), "t.off", {}, scene);
}

Mesh parse_one(const std::string& text) {
  Scene scene;
  Status status = parse(text, &scene);
  EXPECT_TRUE(status.ok()) << status.message();
  if (!status.ok() || scene.parts.size() != 1) {
    ADD_FAILURE() << "expected one part";
    return {};
  }
  return std::move(scene.parts[0]);
}

std::string parse_message(const std::string& text) {
  Scene scene;
  return parse(text, &scene).message();
}

// A unit cube: 8 vertices, 6 quads.
const char* const kCube =
    "OFF\n"
    "8 6 12\n"
    "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n"
    "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n4 3 0 4 7\n";

TEST(IoOff, CubeQuadsAreFannedInFaceOrder) {
  Mesh mesh = parse_one(kCube);
  ASSERT_EQ(mesh.positions.size(), 8u);
  EXPECT_EQ(mesh.positions[6], (Vec3{1, 1, 1}));
  EXPECT_EQ(mesh.stored_vertices, 8u);
  ASSERT_EQ(mesh.triangle_count(), 12u);
  // Face f gives triangles 2f and 2f + 1: (a b c d) -> (a b c) (a c d).
  EXPECT_EQ(std::vector<uint32_t>(mesh.indices.begin(), mesh.indices.begin() + 6),
            (std::vector<uint32_t>{0, 3, 2, 0, 2, 1}));
  EXPECT_EQ(std::vector<uint32_t>(mesh.indices.end() - 6, mesh.indices.end()),
            (std::vector<uint32_t>{3, 0, 4, 3, 4, 7}));
  EXPECT_TRUE(mesh.normals.empty());
  EXPECT_TRUE(mesh.name.empty());
}

TEST(IoOff, MixedPolygonsAndShortFaces) {
  Mesh mesh = parse_one(
      "OFF\n5 4 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 0.5 0\n"
      "5 0 1 4 2 3\n2 0 1\n3 0 1 2\n1 4\n");
  // The pentagon gives three triangles, then the 2-corner face none, the triangle one.
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 4, 0, 4, 2, 0, 2, 3, 0, 1, 2}));
}

TEST(IoOff, CommentsBlankLinesCrLfAndLayouts) {
  Mesh reference = parse_one("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  const std::string variants[] = {
      "# leading comment\n\nOFF # keyword comment\n# between\n3 1 0 # counts\n"
      "0 0 0 # first\n\n1 0 0\n# vertex comment\n0 1 0\n3 0 1 2 # face\n",
      "OFF\r\n3 1 0\r\n0 0 0\r\n1 0 0\r\n0 1 0\r\n3 0 1 2\r\n",
      "OFF 3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2",   // counts on the keyword line, no final newline
      "OFF\n3 1\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",  // no edge count
      "3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",     // no keyword
      "OFF\n3 1 0\n0 0\n0\n1 0 0\n0 1 0\n3\n0 1\n2\n",  // values wrapped over lines
      "OFF\n3 1 0\n+0.0 0e0 0\n1.0 0 -0\n0 1. 0\n3 +0 1 2\n",
      "nOFF\n3\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
  };
  for (const std::string& text : variants) {
    Mesh mesh = parse_one(text);
    EXPECT_EQ(mesh.positions, reference.positions) << text;
    EXPECT_EQ(mesh.indices, reference.indices) << text;
  }
}

TEST(IoOff, ColoursNormalsAndTexturesAreHandled) {
  // COFF: RGBA floats per vertex; faces with integer and float colours (as the Princeton
  // benchmark's files may have).
  Mesh coff = parse_one(
      "COFF\n4 2 0\n0 0 0 1 0 0 1\n1 0 0 0 1 0 1\n1 1 0 0 0 1 1\n0 1 0 255 255 255 255\n"
      "3 0 1 2 255 0 0\n3 0 2 3 0.5 0.5 0.5 1\n");
  EXPECT_EQ(coff.positions[3], (Vec3{0, 1, 0}));
  EXPECT_EQ(coff.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
  EXPECT_TRUE(coff.normals.empty());

  Mesh noff = parse_one("NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 1 0\n3 0 1 2\n");
  EXPECT_EQ(noff.positions, (std::vector<Vec3>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}));
  EXPECT_EQ(noff.normals, (std::vector<Vec3>{{0, 0, 1}, {0, 0, 1}, {0, 1, 0}}));

  Mesh cnoff = parse_one(
      "CNOFF\n3 1 0\n0 0 0 0 0 1 9 9 9 9\n1 0 0 0 0 1 9 9 9 9\n0 1 0 1 0 0 9 9 9 9\n3 0 1 2\n");
  EXPECT_EQ(cnoff.positions, noff.positions);
  EXPECT_EQ(cnoff.normals[2], (Vec3{1, 0, 0}));

  Mesh stcnoff = parse_one(
      "STCNOFF\n3 1 0\n0 0 0 0 0 1 1 1 1 1 0.5 0.5\n1 0 0 0 0 1 1 1 1 1 0 0\n"
      "0 1 0 0 0 1 1 1 1 1 1 1\n3 0 1 2\n");
  EXPECT_EQ(stcnoff.positions, noff.positions);
  EXPECT_EQ(stcnoff.normals.size(), 3u);

  Mesh bad_normal = parse_one("NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 inf 0 1\n0 1 0 0 1 0\n3 0 1 2\n");
  EXPECT_TRUE(bad_normal.normals.empty());
  EXPECT_EQ(bad_normal.positions.size(), 3u);
}

TEST(IoOff, ThroughReadMemoryWeldsAndNames) {
  Scene scene = test::parse_or_fail(kCube, "models/cube.off");
  ASSERT_EQ(scene.parts.size(), 1u);
  EXPECT_EQ(scene.parts[0].name, "cube");
  EXPECT_EQ(scene.parts[0].triangle_count(), 12u);
  EXPECT_EQ(scene.parts[0].stored_vertices, 8u);
}

// ---- hostile bytes --------------------------------------------------------------------------

TEST(IoOff, UnsupportedVariants) {
  Scene scene;
  Status status = parse("OFF BINARY\n3 1 0\n", &scene);
  EXPECT_EQ(status.code(), ErrorCode::kUnsupported);
  EXPECT_EQ(status.message(), "t.off: binary OFF is not supported (line 1)");
  status = parse("4OFF\n3 1 0\n0 0 0 1\n1 0 0 1\n0 1 0 1\n3 0 1 2\n", &scene);
  EXPECT_EQ(status.code(), ErrorCode::kUnsupported);
  EXPECT_NE(status.message().find("4OFF"), std::string::npos);
  status = parse("nOFF 4\n3 1 0\n", &scene);
  EXPECT_EQ(status.code(), ErrorCode::kUnsupported);
  EXPECT_NE(status.message().find("nOFF of dimension 4"), std::string::npos);
}

TEST(IoOff, TruncatedAtEveryByteIsAnErrorNeverACrash) {
  // Ends in a one-digit index and a newline: any shorter prefix but the one without that newline
  // misses a value.
  std::string file =
      "COFF\n4 2 0\n0 0 0 1 1 1 1\n1 0 0 1 1 1 1\n1 1 0 1 1 1 1\n0.5 1 0\n"
      "4 0 1 2 3 9 9 9\n3 0 2 3\n";
  ASSERT_EQ(parse_message(file), "");
  for (size_t cut = 0; cut + 1 < file.size(); ++cut) {
    std::string message = parse_message(file.substr(0, cut));
    EXPECT_NE(message, "") << "cut at byte " << cut;
    EXPECT_EQ(message.rfind("t.off: ", 0), 0u) << message;
  }
  EXPECT_EQ(parse_message(file.substr(0, file.size() - 1)), "");
}

TEST(IoOff, CountsLargerThanTheFileFailFast) {
  std::string message = parse_message("OFF\n4000000000 1 0\n0 0 0\n");
  EXPECT_NE(message.find("4000000000 vertices and 1 faces declared, more than the 6 bytes"),
            std::string::npos)
      << message;
  EXPECT_NE(message.find("(line 2)"), std::string::npos) << message;
  message = parse_message("OFF\n3 9223372036854775807 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_NE(message.find("9223372036854775807 faces declared"), std::string::npos) << message;
  message = parse_message("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2000000000 0 1 2\n");
  EXPECT_NE(message.find("face 0: bad corner count '2000000000'"), std::string::npos) << message;
}

TEST(IoOff, BadValuesAreErrorsWithLines) {
  struct Case {
    std::string text;
    std::string expected;
  };
  const Case cases[] = {
      {"", "t.off: the file is empty (line 1)"},
      {"\n\n# only a comment\n", "the file is empty"},
      {"\x7f"
       "ELF\x02\x01",
       "not an OFF file: it begins with '?ELF?"
       "?'"},
      {"MOFF\n3 1 0\n", "not an OFF file"},
      {"OFF\n", "the file ends before the vertex count"},
      {"OFF\n-3 1 0\n", "bad vertex count '-3'"},
      {"OFF\n3 x 0\n", "bad face count 'x'"},
      {"OFF\n3 1 0\n0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n",
       "vertex 1: 'zero' is not a number (line 4)"},
      {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 nan 0\n3 0 1 2\n",
       "vertex 2 has a NaN or infinite coordinate (line 5)"},
      {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1e39 0\n3 0 1 2\n", "vertex 2 has a NaN or infinite"},
      {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
       "face 0: vertex index 3 out of range (3 vertices) (line 6)"},
      {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", "vertex index -1 out of range"},
      {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 two\n", "face 0: 'two' is not a vertex index"},
      {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n-3 0 1 2\n", "face 0: bad corner count '-3'"},
      {"OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "the file ends after 1 of 2 faces"},
      {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1\n", "the file ends in face 0"},
      {"OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n", "t.off: no triangles"},
      {"OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n1 2\n",
       "no triangles: all 2 faces have fewer than 3 corners"},
  };
  for (const Case& c : cases) {
    std::string message = parse_message(c.text);
    EXPECT_NE(message.find(c.expected), std::string::npos)
        << "expected '" << c.expected << "' in '" << message << "'";
  }
}

// ---- real data ------------------------------------------------------------------------------

/// STATS.csv rows by path: the named columns as text.
std::map<std::string, std::map<std::string, std::string>> read_stats(const std::string& path) {
  std::map<std::string, std::map<std::string, std::string>> rows;
  std::ifstream in(path);
  std::string line;
  std::vector<std::string> header;
  auto split = [](const std::string& s) {
    std::vector<std::string> cells;
    std::stringstream ss(s);
    std::string cell;
    while (std::getline(ss, cell, ',')) cells.push_back(cell);
    return cells;
  };
  if (std::getline(in, line)) header = split(line);
  while (std::getline(in, line)) {
    std::vector<std::string> cells = split(line);
    if (cells.size() != header.size()) continue;
    auto& row = rows[cells[0]];
    for (size_t i = 0; i < header.size(); ++i) row[header[i]] = cells[i];
  }
  return rows;
}

TEST(IoOff, SegmentationBenchmarkMatchesStats) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  auto stats = read_stats(data + "/STATS.csv");
  std::string folder = data + "/cearto__zen__MeshsegBenchmark/data/off";
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) {
    if (entry.path().extension() == ".off") files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  EXPECT_EQ(files.size(), 38u);
  for (const auto& file : files) {
    std::string relative = "cearto__zen__MeshsegBenchmark/data/off/" + file.filename().string();
    SCOPED_TRACE(relative);
    ASSERT_EQ(stats.count(relative), 1u);
    const auto& row = stats[relative];
    std::vector<uint8_t> bytes = test::read_bytes(file.string());
    Scene scene;
    Status status = parse_off(bytes.data(), bytes.size(), file.string(), {}, &scene);
    ASSERT_TRUE(status.ok()) << status.message();
    ASSERT_EQ(scene.parts.size(), 1u);
    const Mesh& mesh = scene.parts[0];
    EXPECT_EQ(std::to_string(mesh.triangle_count()), row.at("triangles"));
    EXPECT_EQ(std::to_string(mesh.stored_vertices), row.at("stored_vertices"));
    EXPECT_EQ(mesh.positions.size(), mesh.stored_vertices);
  }
  // One label per face in file order: the segmentations have one line per triangle.
  std::ifstream seg(data + "/cearto__zen__MeshsegBenchmark/data/seg/Benchmark/1/1_0.seg");
  size_t lines = 0;
  for (std::string line; std::getline(seg, line);) ++lines;
  EXPECT_EQ(std::to_string(lines),
            stats["cearto__zen__MeshsegBenchmark/data/off/1.off"].at("triangles"));
}

}  // namespace io_off_test
}  // namespace
}  // namespace osteon
