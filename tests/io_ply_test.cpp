// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "fixtures.hpp"
#include "io_internal.hpp"
#include "osteon/io.hpp"

namespace osteon {
namespace {
namespace io_ply_test {

using detail::parse_ply;

Status parse(const std::string& bytes, Scene* scene, const std::string& source = "t.ply") {
  return parse_ply(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), source, {}, scene);
}

/// The one mesh parse_ply gives for these bytes (fails the test on error).
Mesh parse_one(const std::string& bytes) {
  Scene scene;
  Status status = parse(bytes, &scene);
  EXPECT_TRUE(status.ok()) << status.message();
  if (!status.ok() || scene.parts.size() != 1) {
    ADD_FAILURE() << "expected one part";
    return {};
  }
  return std::move(scene.parts[0]);
}

/// The error message parse_ply gives ("" when it succeeds).
std::string parse_message(const std::string& bytes) {
  Scene scene;
  return parse(bytes, &scene).message();
}

/// Appends `value` in byte order `order`.
template <class T>
void put(std::string& out, T value, std::endian order = std::endian::little) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  if (order != std::endian::native) {
    for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
  }
  out.append(bytes, sizeof(T));
}

const std::vector<Vec3> kSquare = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};

/// Binary little-endian: float x y z, uchar-counted int lists: the fast path.
std::string fast_path_file(const std::vector<Vec3>& positions,
                           const std::vector<std::vector<int32_t>>& faces,
                           std::endian order = std::endian::little) {
  std::string s = "ply\nformat ";
  s += order == std::endian::little ? "binary_little_endian" : "binary_big_endian";
  s += " 1.0\ncomment made by hand\nelement vertex " + std::to_string(positions.size()) +
       "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
       std::to_string(faces.size()) + "\nproperty list uchar int vertex_indices\nend_header\n";
  for (const Vec3& p : positions) {
    put(s, p.x, order);
    put(s, p.y, order);
    put(s, p.z, order);
  }
  for (const auto& face : faces) {
    put(s, static_cast<uint8_t>(face.size()));
    for (int32_t i : face) put(s, i, order);
  }
  return s;
}

TEST(IoPly, AsciiTriangleAndQuad) {
  std::string file =
      "ply\r\nformat ascii 1.0\r\ncomment hello\r\nobj_info nothing\r\nelement vertex 5\r\n"
      "property float x\r\nproperty float y\r\nproperty float z\r\nelement face 2\r\n"
      "property list uchar int vertex_indices\r\nend_header\r\n"
      "0 0 0\r\n1 0 0\r\n1 1 0\r\n0 1 0\r\n0.5 -2.25 1e2\r\n"
      "4 0 1 2 3\r\n3 0 4 1\r\n";
  Mesh mesh = parse_one(file);
  ASSERT_EQ(mesh.positions.size(), 5u);
  EXPECT_EQ(mesh.positions[4], (Vec3{0.5f, -2.25f, 100.0f}));
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 0, 4, 1}));
  EXPECT_EQ(mesh.stored_vertices, 5u);
  EXPECT_TRUE(mesh.normals.empty());
  EXPECT_TRUE(mesh.name.empty());
}

TEST(IoPly, BinaryFastPathBothByteOrders) {
  for (std::endian order : {std::endian::little, std::endian::big}) {
    std::vector<Vec3> positions = kSquare;
    positions.push_back({-1.5f, 2.5f, 3.25f});
    // A quad (fan), a triangle, a pentagon, and faces of 0 and 2 corners (skipped).
    Mesh mesh = parse_one(
        fast_path_file(positions, {{0, 1, 2, 3}, {4, 0, 1}, {0, 1, 2, 3, 4}, {}, {1, 2}}, order));
    EXPECT_EQ(mesh.positions, positions);
    EXPECT_EQ(mesh.indices,
              (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 4, 0, 1, 0, 1, 2, 0, 2, 3, 0, 3, 4}));
    EXPECT_EQ(mesh.stored_vertices, 5u);
  }
}

TEST(IoPly, UnusualLayoutBigEndianGenericPath) {
  // Extra properties before x, z before y, double x, uint16 list counts, uint32 indices, a face
  // property before the list and a list property after it, and normals.
  std::string s =
      "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty uchar red\n"
      "property double x\nproperty float nz\nproperty short z\nproperty float y\n"
      "property float nx\nproperty list uchar float weights\nproperty float ny\n"
      "element face 1\nproperty int flags\nproperty list ushort uint vertex_indices\n"
      "property list uchar float texcoord\nend_header\n";
  auto order = std::endian::big;
  const double xs[3] = {0.25, 1e-3, -7.0};
  for (int v = 0; v < 3; ++v) {
    put<uint8_t>(s, 200);
    put<double>(s, xs[v], order);
    put<float>(s, 1.0f, order);  // nz
    put<int16_t>(s, static_cast<int16_t>(-300 + v), order);
    put<float>(s, 2.0f * v, order);
    put<float>(s, 0.0f, order);  // nx
    put<uint8_t>(s, 2);          // two weights
    put<float>(s, 9.0f, order);
    put<float>(s, 9.0f, order);
    put<float>(s, 0.0f, order);  // ny
  }
  put<int32_t>(s, -5, order);
  put<uint16_t>(s, 3, order);
  put<uint32_t>(s, 2, order);
  put<uint32_t>(s, 0, order);
  put<uint32_t>(s, 1, order);
  put<uint8_t>(s, 6);
  for (int i = 0; i < 6; ++i) put<float>(s, 0.5f, order);

  Mesh mesh = parse_one(s);
  ASSERT_EQ(mesh.positions.size(), 3u);
  EXPECT_EQ(mesh.positions[0], (Vec3{0.25f, 0.0f, -300.0f}));
  EXPECT_EQ(mesh.positions[1], (Vec3{static_cast<float>(1e-3), 2.0f, -299.0f}));
  EXPECT_EQ(mesh.positions[2], (Vec3{-7.0f, 4.0f, -298.0f}));
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{2, 0, 1}));
  ASSERT_EQ(mesh.normals.size(), 3u);
  EXPECT_EQ(mesh.normals[1], (Vec3{0, 0, 1}));
}

TEST(IoPly, EveryScalarTypeAsCoordinateAndIndex) {
  struct Case {
    const char* name;
    std::string (*bytes)(double, std::endian);
  };
  auto encode = [](auto tag) {
    return +[](double v, std::endian order) {
      std::string s;
      put(s, static_cast<decltype(tag)>(v), order);
      return s;
    };
  };
  const Case cases[] = {
      {"char", encode(int8_t{})},     {"int8", encode(int8_t{})},
      {"uchar", encode(uint8_t{})},   {"uint8", encode(uint8_t{})},
      {"short", encode(int16_t{})},   {"int16", encode(int16_t{})},
      {"ushort", encode(uint16_t{})}, {"uint16", encode(uint16_t{})},
      {"int", encode(int32_t{})},     {"int32", encode(int32_t{})},
      {"uint", encode(uint32_t{})},   {"uint32", encode(uint32_t{})},
      {"float", encode(float{})},     {"float32", encode(float{})},
      {"double", encode(double{})},   {"float64", encode(double{})},
  };
  for (const Case& c : cases) {
    for (std::endian order : {std::endian::little, std::endian::big}) {
      SCOPED_TRACE(std::string(c.name) + (order == std::endian::little ? " le" : " be"));
      std::string type = c.name;
      bool is_signed = type.find('u') == std::string::npos;
      std::string s = "ply\nformat ";
      s += order == std::endian::little ? "binary_little_endian" : "binary_big_endian";
      s += " 1.0\nelement vertex 3\nproperty " + type + " x\nproperty " + type + " y\nproperty " +
           type + " z\nelement face 1\nproperty list " +
           (type.find("float") == std::string::npos && type != "double" ? type : "uchar") + " " +
           type + " vertex_indices\nend_header\n";
      for (int v = 0; v < 3; ++v) {
        s += c.bytes(is_signed ? -v : 100 + v, order);
        s += c.bytes(7, order);
        s += c.bytes(v, order);
      }
      s += type.find("float") == std::string::npos && type != "double" ? c.bytes(3, order)
                                                                       : std::string(1, '\3');
      for (int i : {2, 1, 0}) s += c.bytes(i, order);
      Mesh mesh = parse_one(s);
      ASSERT_EQ(mesh.positions.size(), 3u);
      EXPECT_EQ(mesh.positions[2], (Vec3{is_signed ? -2.0f : 102.0f, 7.0f, 2.0f}));
      EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{2, 1, 0}));
    }
  }
}

TEST(IoPly, UnknownElementsAreSkippedAsciiAndBinary) {
  // A material element with a list before the vertices, an edge element after the faces.
  std::string head =
      "element material 2\nproperty list uchar int ids\nproperty float shine\n"
      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "property list int uchar rgb_list\n"
      "element face 1\nproperty list uchar int vertex_index\n"
      "element edge 2\nproperty int a\nproperty int b\nelement nothing 5\nend_header\n";
  std::string ascii = "ply\nformat ascii 1.0\n" + head +
                      "3 1 2 3 0.5\n0 1.5\n"
                      "0 0 0 0\n1 0 0 2 7 7\n0 1 0 1 9\n"
                      "3 0 1 2\n0 1\n1 2\n";
  Mesh a = parse_one(ascii);
  EXPECT_EQ(a.positions, (std::vector<Vec3>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}));
  EXPECT_EQ(a.indices, (std::vector<uint32_t>{0, 1, 2}));

  std::string binary = "ply\nformat binary_little_endian 1.0\n" + head;
  put<uint8_t>(binary, 3);
  for (int i : {1, 2, 3}) put<int32_t>(binary, i);
  put<float>(binary, 0.5f);
  put<uint8_t>(binary, 0);
  put<float>(binary, 1.5f);
  const float xyz[3][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  for (int v = 0; v < 3; ++v) {
    for (float f : xyz[v]) put<float>(binary, f);
    put<int32_t>(binary, v);
    for (int k = 0; k < v; ++k) put<uint8_t>(binary, 7);
  }
  put<uint8_t>(binary, 3);
  for (int i : {0, 1, 2}) put<int32_t>(binary, i);
  for (int i : {0, 1, 1, 2}) put<int32_t>(binary, i);
  Mesh b = parse_one(binary);
  EXPECT_EQ(b.positions, a.positions);
  EXPECT_EQ(b.indices, a.indices);
}

TEST(IoPly, FacesBeforeVerticesAndTriStrips) {
  std::string file =
      "ply\nformat ascii 1.0\nelement tristrips 1\nproperty list int int vertex_indices\n"
      "element vertex 6\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
      // Strip 0 1 2 3, restart, strip 3 4 5 with a stitch (4 4) that gives degenerate triangles.
      "9 0 1 2 3 -1 3 4 4 5\n"
      "0 0 0\n1 0 0\n0 1 0\n1 1 0\n2 0 0\n2 1 0\n";
  Mesh mesh = parse_one(file);
  // 0 1 2, then 2 1 3 (odd: swapped); 3 4 4 and 4 4 5 dropped as degenerate.
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2, 2, 1, 3}));
  EXPECT_EQ(mesh.positions.size(), 6u);
}

TEST(IoPly, NormalsKeptWhenFiniteDroppedOtherwise) {
  std::string head =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
      "element face 1\nproperty list uchar uint vertex_indices\nend_header\n";
  Mesh good = parse_one(head + "0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 1 0\n3 0 1 2\n");
  EXPECT_EQ(good.normals, (std::vector<Vec3>{{0, 0, 1}, {0, 0, 1}, {0, 1, 0}}));
  Mesh bad = parse_one(head + "0 0 0 0 0 1\n1 0 0 nan 0 1\n0 1 0 0 1 0\n3 0 1 2\n");
  EXPECT_TRUE(bad.normals.empty());
  EXPECT_EQ(bad.positions.size(), 3u);
  // Only nx and ny: no normals.
  Mesh partial = parse_one(
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float nx\n"
      "property float y\nproperty float ny\nproperty float z\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n"
      "0 9 0 9 0\n1 9 0 9 0\n0 9 1 9 0\n3 0 1 2\n");
  EXPECT_TRUE(partial.normals.empty());
  EXPECT_EQ(partial.positions[2], (Vec3{0, 1, 0}));
}

TEST(IoPly, ShortFacesAreSkippedAndAllShortIsAnError) {
  std::string head =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 3\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n";
  Mesh mesh = parse_one(head + "0\n3 0 1 2\n2 0 1\n");
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2}));
  EXPECT_NE(parse_message(head + "0\n1 0\n2 0 1\n").find("no triangles: all 3 faces"),
            std::string::npos);
  // Short faces still have their indices checked.
  EXPECT_NE(parse_message(head + "0\n3 0 1 2\n2 0 9\n").find("out of range"), std::string::npos);
}

TEST(IoPly, ThroughReadMemory) {
  std::string file = fast_path_file(kSquare, {{0, 1, 2}, {0, 2, 3}});
  ReadOptions options;
  options.weld = false;
  Scene scene = test::parse_or_fail(file, "dir/square.ply", options);
  ASSERT_EQ(scene.parts.size(), 1u);
  EXPECT_EQ(scene.parts[0].name, "square");
  EXPECT_EQ(scene.parts[0].triangle_count(), 2u);
  // Sniffed from the bytes when the name has no extension.
  auto sniffed = read_memory(reinterpret_cast<const uint8_t*>(file.data()), file.size(), "blob");
  ASSERT_TRUE(sniffed.ok()) << sniffed.status().message();
  EXPECT_EQ(sniffed->parts[0].positions.size(), 4u);
}

// ---- hostile bytes --------------------------------------------------------------------------

TEST(IoPly, TruncatedAtEveryByteIsAnError) {
  std::vector<std::string> files = {
      fast_path_file(kSquare, {{0, 1, 2, 3}, {0, 2, 1}}),
      fast_path_file(kSquare, {{0, 1, 2, 3}, {0, 2, 1}}, std::endian::big),
  };
  // The generic path: a double coordinate, a ushort-counted list, an unknown list element.
  std::string generic =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty double x\n"
      "property float y\nproperty float z\nelement face 1\nproperty uchar flags\n"
      "property list ushort int vertex_indices\nelement extra 1\n"
      "property list uchar short stuff\nend_header\n";
  for (int v = 0; v < 3; ++v) {
    put<double>(generic, v);
    put<float>(generic, 1.0f);
    put<float>(generic, 2.0f);
  }
  put<uint8_t>(generic, 1);
  put<uint16_t>(generic, 3);
  for (int i : {0, 1, 2}) put<int32_t>(generic, i);
  put<uint8_t>(generic, 2);
  put<int16_t>(generic, 5);
  put<int16_t>(generic, 6);
  files.push_back(generic);
  for (const std::string& file : files) {
    ASSERT_EQ(parse_message(file), "");
    for (size_t cut = 0; cut < file.size(); ++cut) {
      std::string message = parse_message(file.substr(0, cut));
      EXPECT_NE(message, "") << "cut at byte " << cut << " of " << file.size();
      EXPECT_EQ(message.rfind("t.ply: ", 0), 0u) << message;
    }
  }
}

TEST(IoPly, CountsLargerThanTheFileFailFast) {
  auto start = std::chrono::steady_clock::now();
  std::string vertex =
      "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n"
      "property float y\nproperty float z\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n" +
      std::string(40, '\0');
  std::string message = parse_message(vertex);
  EXPECT_NE(message.find("element 'vertex' declares 4000000000 items"), std::string::npos)
      << message;
  EXPECT_NE(message.find("(byte "), std::string::npos) << message;

  std::string face = fast_path_file(kSquare, {{0, 1, 2}});
  face.replace(face.find("element face 1"), 14, "element face 99999999999");
  message = parse_message(face);
  EXPECT_NE(message.find("element 'face' declares 99999999999 items"), std::string::npos)
      << message;

  std::string ascii =
      "ply\nformat ascii 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n";
  message = parse_message(ascii);
  EXPECT_NE(message.find("4000000000"), std::string::npos) << message;

  // A list that claims more items than the file holds.
  std::string list = fast_path_file(kSquare, {{0, 1, 2}});
  list[list.size() - 13] = static_cast<char>(200);
  message = parse_message(list);
  EXPECT_NE(message.find("the file ends"), std::string::npos) << message;
  // An unknown element of huge count whose items have no properties costs nothing.
  std::string empty_element = fast_path_file(kSquare, {{0, 1, 2}});
  empty_element.replace(empty_element.find("end_header"), 10,
                        "element nothing 18446744073709551615\nend_header");
  EXPECT_NE(parse_message(empty_element).find("bad element line"), std::string::npos);
  empty_element = fast_path_file(kSquare, {{0, 1, 2}});
  empty_element.replace(empty_element.find("end_header"), 10,
                        "element nothing 9223372036854775807\nend_header");
  EXPECT_EQ(parse_message(empty_element), "");
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(2));
}

TEST(IoPly, NonFiniteCoordinatesAreErrors) {
  float inf = std::numeric_limits<float>::infinity();
  std::string message =
      parse_message(fast_path_file({{0, 0, 0}, {1, 0, 0}, {0, inf, 0}}, {{0, 1, 2}}));
  EXPECT_NE(message.find("vertex 2 has a NaN or infinite coordinate"), std::string::npos)
      << message;
  EXPECT_NE(message.find("(byte "), std::string::npos) << message;
  std::string ascii =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n";
  message = parse_message(ascii);
  EXPECT_NE(message.find("vertex 1 has a NaN or infinite coordinate (line 11)"), std::string::npos)
      << message;
  // A double too large for a float is infinite once stored.
  std::string big =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty double x\n"
      "property double y\nproperty double z\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n";
  for (double v : {0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1e300, 0.0}) put<double>(big, v);
  put<uint8_t>(big, 3);
  for (int i : {0, 1, 2}) put<int32_t>(big, i);
  EXPECT_NE(parse_message(big).find("vertex 2 has a NaN"), std::string::npos);
}

TEST(IoPly, IndicesOutOfRangeAreErrors) {
  std::string message = parse_message(fast_path_file(kSquare, {{0, 1, 2}, {0, 4, 1}}));
  EXPECT_NE(message.find("element 'face' item 1: vertex index 4 out of range (4 vertices)"),
            std::string::npos)
      << message;
  // The face starts after the header, 4 * 12 vertex bytes and the first face's 13 bytes.
  std::string file = fast_path_file(kSquare, {{0, 1, 2}, {0, 4, 1}});
  size_t face_offset = file.find("end_header\n") + 11 + 48 + 13;
  EXPECT_NE(message.find("(byte " + std::to_string(face_offset) + ")"), std::string::npos)
      << message;
  // No vertices at all (found by fuzzing: the fast path must not copy from an empty block).
  message = parse_message(fast_path_file({}, {{0, 1, 2}}));
  EXPECT_NE(message.find("vertex index 0 out of range (0 vertices)"), std::string::npos) << message;
  message = parse_message(fast_path_file(kSquare, {{0, -1, 2}}));
  EXPECT_NE(message.find("vertex index -1 out of range"), std::string::npos) << message;
  message = parse_message(fast_path_file(kSquare, {{0, 1, 2, 3, 7}}));
  EXPECT_NE(message.find("vertex index 7 out of range"), std::string::npos) << message;
  std::string ascii =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n";
  message = parse_message(ascii);
  EXPECT_NE(message.find("vertex index 3 out of range (3 vertices) (line 13)"), std::string::npos)
      << message;
}

TEST(IoPly, BadHeadersAndGarbage) {
  struct Case {
    std::string bytes;
    std::string expected;
  };
  std::string vertex = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
  std::string face = "element face 1\nproperty list uchar int vertex_indices\n";
  const Case cases[] = {
      {"", "does not begin with 'ply'"},
      {"\x01\x02garbage\xff", "does not begin with 'ply'"},
      {"solid cube\nfacet normal 0 0 1\n", "does not begin with 'ply'"},
      {"ply\nformat ascii 1.0\n" + vertex + face, "no end_header"},
      {"ply\n" + vertex + face + "end_header\n", "no format line"},
      {"ply\nformat binary_middle_endian 1.0\nend_header\n", "unknown PLY format"},
      {"ply\nformat ascii 2.0\nend_header\n", "PLY version '2.0'"},
      {"ply\nformat ascii 1.0\nproperty float x\nend_header\n", "property before any element"},
      {"ply\nformat ascii 1.0\nelement vertex 3\nproperty quad x\nend_header\n",
       "unknown property type 'quad' (line 4)"},
      {"ply\nformat ascii 1.0\nelement vertex 3\nproperty list float int x\nend_header\n",
       "list count type 'float' is not an integer type"},
      {"ply\nformat ascii 1.0\nelement vertex -3\nend_header\n", "bad element line"},
      {"ply\nformat ascii 1.0\nelement vertex 3\nelement vertex 3\nend_header\n", "declared twice"},
      {"ply\nformat ascii 1.0\nbogus line\nend_header\n", "unknown header line 'bogus'"},
      {"ply\nformat ascii 1.0\n" + face + "end_header\n3 0 1 2\n", "no vertex element"},
      {"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n" + face +
           "end_header\n",
       "lacks a scalar x, y or z"},
      {"ply\nformat ascii 1.0\n" + vertex + "end_header\n0 0 0\n1 0 0\n0 1 0\n",
       "no triangles: the header declares no face"},
      {"ply\nformat ascii 1.0\n" + vertex +
           "element face 1\nproperty list uchar int corners\nend_header\n",
       "has no vertex_indices list"},
      {"ply\nformat ascii 1.0\n" + vertex + face + "end_header\n0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n",
       "'zero' is not a number"},
      {"ply\nformat ascii 1.0\n" + vertex + face + "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2.5\n",
       "'2.5' is not an integer"},
      {"ply\nformat ascii 1.0\n" + vertex + face + "end_header\n0 0 0\n1 0 0\n0 1 0\n300 0 1 2\n",
       "'300' is out of range"},
      {"ply\nformat ascii 1.0\n" + vertex + face + "end_header\n0 0 0\n1 0 0\n0 1 0\n0\n",
       "no triangles"},
  };
  for (const Case& c : cases) {
    std::string message = parse_message(c.bytes);
    EXPECT_NE(message.find(c.expected), std::string::npos)
        << "expected '" << c.expected << "' in '" << message << "'";
  }
  EXPECT_EQ(test::parse_error("", "empty.ply"), "empty.ply: file is empty (byte 0)");
}

// ---- real data ------------------------------------------------------------------------------

TEST(IoPly, CtLikeFilesMatchTheirHeaders) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  struct Expected {
    const char* file;
    size_t vertices;
    size_t triangles;
  };
  for (const Expected& e :
       {Expected{"hip_mcs.ply", 529962, 1059928}, Expected{"skull_mc.ply", 749621, 1499782}}) {
    std::string path = data + "/ct-like/" + e.file;
    std::vector<uint8_t> bytes = test::read_bytes(path);
    ASSERT_FALSE(bytes.empty()) << path;
    Scene scene;
    Status status = parse_ply(bytes.data(), bytes.size(), path, {}, &scene);
    ASSERT_TRUE(status.ok()) << status.message();
    ASSERT_EQ(scene.parts.size(), 1u);
    const Mesh& mesh = scene.parts[0];
    EXPECT_EQ(mesh.positions.size(), e.vertices) << e.file;
    EXPECT_EQ(mesh.stored_vertices, e.vertices) << e.file;
    EXPECT_EQ(mesh.triangle_count(), e.triangles) << e.file;
    EXPECT_TRUE(mesh.normals.empty());
  }
}

}  // namespace io_ply_test
}  // namespace
}  // namespace osteon
