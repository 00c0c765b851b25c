// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>
#include <draco/compression/encode.h>
#include <draco/mesh/triangle_soup_mesh_builder.h>
#include <meshoptimizer.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <array>
#include <algorithm>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fixtures.hpp"
#include "osteon/io.hpp"
#include "osteon/mesh.hpp"

namespace osteon {
namespace {
namespace io_gltf_test {

using nlohmann::json;
using test::parse_error;
using test::parse_or_fail;

constexpr int kUByte = 5121, kShort = 5122, kUShort = 5123, kUInt = 5125, kFloat = 5126;

ReadOptions no_weld() {
  ReadOptions options;
  options.weld = false;
  return options;
}

std::string base64(const std::string& bytes) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    uint32_t v = (uint8_t(bytes[i]) << 16) | (uint8_t(bytes[i + 1]) << 8) | uint8_t(bytes[i + 2]);
    for (int k = 3; k >= 0; --k) out += kAlphabet[(v >> (6 * k)) & 63];
  }
  if (i + 1 == bytes.size()) {
    uint32_t v = uint8_t(bytes[i]) << 16;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == bytes.size()) {
    uint32_t v = (uint8_t(bytes[i]) << 16) | (uint8_t(bytes[i + 1]) << 8);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

template <class T>
std::string le(T value) {
  std::string out(sizeof(T), '\0');
  std::memcpy(out.data(), &value, sizeof(T));  // the test machines are little-endian
  return out;
}

// Assembles glTF JSON and one binary buffer by hand, so that tests control every field
// (including the invalid ones).
struct Builder {
  json root = {{"asset", {{"version", "2.0"}}}};
  std::string bin;

  int push(const char* array, json value) {
    root[array].push_back(std::move(value));
    return static_cast<int>(root[array].size()) - 1;
  }
  int add_view(const std::string& bytes, int stride = 0) {
    while (bin.size() % 4 != 0) bin += '\0';
    json view = {{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", bytes.size()}};
    if (stride != 0) view["byteStride"] = stride;
    bin += bytes;
    return push("bufferViews", view);
  }
  int add_accessor(int view, int component_type, size_t count, const char* type,
                   size_t byte_offset = 0, bool normalized = false) {
    json a = {{"componentType", component_type}, {"count", count}, {"type", type}};
    if (view >= 0) a["bufferView"] = view;
    if (byte_offset != 0) a["byteOffset"] = byte_offset;
    if (normalized) a["normalized"] = true;
    return push("accessors", a);
  }
  int add_positions(const std::vector<Vec3>& points) {
    std::string bytes;
    for (const Vec3& p : points) bytes += le(p.x) + le(p.y) + le(p.z);
    return add_accessor(add_view(bytes), kFloat, points.size(), "VEC3");
  }
  int add_indices(const std::vector<uint32_t>& indices, int component_type = kUShort) {
    std::string bytes;
    for (uint32_t i : indices) {
      if (component_type == kUByte) bytes += le(static_cast<uint8_t>(i));
      if (component_type == kUShort) bytes += le(static_cast<uint16_t>(i));
      if (component_type == kUInt) bytes += le(i);
    }
    return add_accessor(add_view(bytes), component_type, indices.size(), "SCALAR");
  }
  int add_mesh(json primitives) { return push("meshes", {{"primitives", primitives}}); }
  int add_node(json node) { return push("nodes", node); }
  void set_scene(std::vector<int> nodes) {
    root["scenes"] = json::array({{{"nodes", nodes}}});
    root["scene"] = 0;
  }

  json with_buffer(bool embed) const {
    json j = root;
    if (!bin.empty()) {
      json buffer = {{"byteLength", bin.size()}};
      if (embed) buffer["uri"] = "data:application/octet-stream;base64," + base64(bin);
      j["buffers"] = json::array({buffer});
    }
    return j;
  }
  std::string gltf() const { return with_buffer(true).dump(); }
  std::string glb() const { return make_glb(with_buffer(false).dump(), bin); }

  static std::string make_glb(std::string text, std::string payload) {
    while (text.size() % 4 != 0) text += ' ';
    while (payload.size() % 4 != 0) payload += '\0';
    std::string out = "glTF" + le(uint32_t{2});
    uint32_t length =
        static_cast<uint32_t>(12 + 8 + text.size() + (payload.empty() ? 0 : 8 + payload.size()));
    out += le(length) + le(static_cast<uint32_t>(text.size())) + "JSON" + text;
    if (!payload.empty()) {
      out += le(static_cast<uint32_t>(payload.size())) + std::string("BIN\0", 4) + payload;
    }
    return out;
  }
};

const std::vector<Vec3> kTriangle = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};

// One node, one triangle primitive with u16 indices.
Builder single_triangle(json node = json::object()) {
  Builder b;
  int pos = b.add_positions(kTriangle);
  int idx = b.add_indices({0, 1, 2});
  int mesh = b.add_mesh(json::array({{{"attributes", {{"POSITION", pos}}}, {"indices", idx}}}));
  node["mesh"] = mesh;
  b.set_scene({b.add_node(node)});
  return b;
}

Status read_status(const std::string& bytes, const std::string& source) {
  return read_memory(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), source).status();
}

void expect_near(const Vec3& a, const Vec3& b, float tolerance = 1e-5f) {
  EXPECT_NEAR(a.x, b.x, tolerance);
  EXPECT_NEAR(a.y, b.y, tolerance);
  EXPECT_NEAR(a.z, b.z, tolerance);
}

Vec3 face_normal(const Mesh& mesh, size_t t) {
  const Vec3& a = mesh.positions[mesh.indices[3 * t]];
  const Vec3& b = mesh.positions[mesh.indices[3 * t + 1]];
  const Vec3& c = mesh.positions[mesh.indices[3 * t + 2]];
  return cross(b - a, c - a);
}

TEST(IoGltf, GlbAndEmbeddedGltfGiveTheSameTriangle) {
  Builder b = single_triangle({{"name", "bone"}});
  for (const auto& [bytes, source] : {std::pair{b.glb(), "m.glb"}, {b.gltf(), "m.gltf"}}) {
    SCOPED_TRACE(source);
    Scene scene = parse_or_fail(bytes, source, no_weld());
    ASSERT_EQ(scene.parts.size(), 1u);
    const Mesh& mesh = scene.parts[0];
    EXPECT_EQ(mesh.name, "m");  // one part: the dispatcher names it after the file
    EXPECT_EQ(mesh.positions, kTriangle);
    EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2}));
    EXPECT_EQ(mesh.stored_vertices, 3u);
    EXPECT_TRUE(mesh.normals.empty());
  }
}

TEST(IoGltf, ContentIsSniffedWithoutAnExtension) {
  Builder b = single_triangle();
  EXPECT_EQ(parse_or_fail(b.glb(), "noext").parts.size(), 1u);
  EXPECT_EQ(parse_or_fail(b.gltf(), "noext").parts.size(), 1u);
}

TEST(IoGltf, NodeHierarchyComposesTranslationRotationScale) {
  Builder b;
  int pos = b.add_positions(kTriangle);
  int mesh_index = b.add_mesh(json::array({{{"attributes", {{"POSITION", pos}}}}}));
  const double s = std::sqrt(0.5);
  int child = b.add_node({{"mesh", mesh_index}, {"translation", {1, 0, 0}}, {"scale", {2, 2, 2}}});
  int parent = b.add_node({{"children", {child}},
                           {"translation", {10, 0, 0}},
                           {"rotation", {0, 0, s, s}}});  // 90 degrees about +z
  b.set_scene({parent});
  Scene scene = parse_or_fail(b.glb(), "m.glb", no_weld());
  ASSERT_EQ(scene.parts.size(), 1u);
  const Mesh& mesh = scene.parts[0];
  ASSERT_EQ(mesh.positions.size(), 3u);
  // child: p -> 2p + (1,0,0); parent: rotate (x,y) -> (-y,x), then + (10,0,0).
  expect_near(mesh.positions[0], {10, 1, 0});
  expect_near(mesh.positions[1], {10, 3, 0});
  expect_near(mesh.positions[2], {8, 1, 0});
  EXPECT_GT(face_normal(mesh, 0).z, 0);  // rotation and positive scale keep the winding
}

TEST(IoGltf, MatrixNode) {
  // Column-major: scale (1, 2, 3), translation (5, 6, 7).
  Builder b = single_triangle({{"matrix", {1, 0, 0, 0, 0, 2, 0, 0, 0, 0, 3, 0, 5, 6, 7, 1}}});
  Scene scene = parse_or_fail(b.gltf(), "m.gltf", no_weld());
  ASSERT_EQ(scene.parts.size(), 1u);
  expect_near(scene.parts[0].positions[0], {5, 6, 7});
  expect_near(scene.parts[0].positions[1], {6, 6, 7});
  expect_near(scene.parts[0].positions[2], {5, 8, 7});
  EXPECT_EQ(parse_error(single_triangle({{"matrix", {1, 0, 0}}}).glb(), "m.glb"),
            "m.glb: matrix has 3 numbers, not 16 (node 0)");
  EXPECT_EQ(parse_error(single_triangle({{"rotation", {0, 0, 0, 0}}}).glb(), "m.glb"),
            "m.glb: rotation is not a unit quaternion (node 0)");
  EXPECT_EQ(parse_error(single_triangle({{"scale", {1, 1}}}).glb(), "m.glb"),
            "m.glb: scale has 2 numbers, not 3 (node 0)");
}

TEST(IoGltf, MirroredNodeFlipsTheWindingAndTheNormals) {
  Builder b;
  int pos = b.add_positions(kTriangle);
  std::string normals;
  for (int i = 0; i < 3; ++i) normals += le(0.6f) + le(0.0f) + le(0.8f);
  int nrm = b.add_accessor(b.add_view(normals), kFloat, 3, "VEC3");
  int idx = b.add_indices({0, 1, 2});
  int mesh = b.add_mesh(
      json::array({{{"attributes", {{"POSITION", pos}, {"NORMAL", nrm}}}, {"indices", idx}}}));
  int plain = b.add_node({{"name", "plain"}, {"mesh", mesh}});
  int mirror = b.add_node({{"name", "mirror"}, {"mesh", mesh}, {"scale", {-1, 2, 1}}});
  b.set_scene({plain, mirror});
  Scene scene = parse_or_fail(b.glb(), "m.glb", no_weld());
  ASSERT_EQ(scene.parts.size(), 2u);
  EXPECT_EQ(scene.parts[0].name, "m/plain");
  EXPECT_EQ(scene.parts[1].name, "m/mirror");
  const Mesh& m = scene.parts[1];
  expect_near(m.positions[1], {-1, 0, 0});
  expect_near(m.positions[2], {0, 2, 0});
  EXPECT_EQ(m.indices, (std::vector<uint32_t>{0, 2, 1}));
  EXPECT_GT(face_normal(m, 0).z, 0);  // still faces +z, like the unmirrored triangle
  EXPECT_GT(face_normal(scene.parts[0], 0).z, 0);
  // Normals: inverse-transpose of diag(-1, 2, 1) is diag(-1, 0.5, 1): (0.6, 0, 0.8) -> (-0.6, 0,
  // 0.8).
  ASSERT_EQ(m.normals.size(), 3u);
  expect_near(m.normals[0], {-0.6f, 0, 0.8f});
  expect_near(scene.parts[0].normals[0], {0.6f, 0, 0.8f});
}

TEST(IoGltf, NonUniformScaleRenormalisesNormals) {
  Builder b;
  int pos = b.add_positions(kTriangle);
  std::string normals;
  for (int i = 0; i < 3; ++i) normals += le(std::sqrt(0.5f)) + le(std::sqrt(0.5f)) + le(0.0f);
  int nrm = b.add_accessor(b.add_view(normals), kFloat, 3, "VEC3");
  int mesh = b.add_mesh(json::array({{{"attributes", {{"POSITION", pos}, {"NORMAL", nrm}}}}}));
  b.set_scene({b.add_node({{"mesh", mesh}, {"scale", {1, 3, 1}}})});
  Scene scene = parse_or_fail(b.glb(), "m.glb", no_weld());
  ASSERT_EQ(scene.parts.size(), 1u);
  // (1, 1, 0) through diag(1, 1/3, 1) = (1, 1/3, 0), normalised.
  float len = std::sqrt(1.0f + 1.0f / 9.0f);
  expect_near(scene.parts[0].normals[2], {1 / len, 1 / 3.0f / len, 0});
}

TEST(IoGltf, TwoNodesSharingAMeshGiveTwoParts) {
  Builder b;
  int pos = b.add_positions(kTriangle);
  int mesh = b.add_mesh(json::array({{{"attributes", {{"POSITION", pos}}}}}));
  int left = b.add_node({{"name", "left"}, {"mesh", mesh}, {"translation", {-5, 0, 0}}});
  int right = b.add_node({{"name", "right"}, {"mesh", mesh}, {"translation", {5, 0, 0}}});
  int unnamed = b.add_node({{"mesh", mesh}});
  b.set_scene({left, right, unnamed});
  Scene scene = parse_or_fail(b.gltf(), "pair.gltf", no_weld());
  ASSERT_EQ(scene.parts.size(), 3u);
  EXPECT_EQ(scene.parts[0].name, "pair/left");
  EXPECT_EQ(scene.parts[1].name, "pair/right");
  EXPECT_EQ(scene.parts[2].name, "pair/2");  // no node name: the dispatcher numbers it
  expect_near(scene.parts[0].positions[1], {-4, 0, 0});
  expect_near(scene.parts[1].positions[1], {6, 0, 0});
  for (const Mesh& part : scene.parts) EXPECT_EQ(part.triangle_count(), 1u);
}

TEST(IoGltf, PrimitivesOfOneMeshMergeIntoOnePart) {
  Builder b;
  std::vector<Vec3> quad = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  int pos = b.add_positions(quad);
  int first = b.add_indices({0, 1, 2}, kUByte);
  int second = b.add_indices({0, 2, 3}, kUInt);
  int other = b.add_positions({{5, 5, 5}, {6, 5, 5}, {5, 6, 5}});
  int lines = b.add_indices({0, 1});
  int mesh = b.add_mesh(json::array({
      {{"attributes", {{"POSITION", pos}}}, {"indices", first}},
      {{"attributes", {{"POSITION", pos}}}, {"indices", second}},  // shares the vertices
      {{"attributes", {{"POSITION", pos}}}, {"indices", lines}, {"mode", 1}},  // skipped
      {{"attributes", json::object()}},                                        // no POSITION
      {{"attributes", {{"POSITION", other}}}},                                 // non-indexed
  }));
  b.set_scene({b.add_node({{"mesh", mesh}})});
  Scene scene = parse_or_fail(b.glb(), "m.glb", no_weld());
  ASSERT_EQ(scene.parts.size(), 1u);
  const Mesh& m = scene.parts[0];
  EXPECT_EQ(m.positions.size(), 7u);
  EXPECT_EQ(m.stored_vertices, 7u);
  EXPECT_EQ(m.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 4, 5, 6}));
}

TEST(IoGltf, IndexComponentTypesAgree) {
  std::vector<uint32_t> expected = {0, 1, 2, 2, 1, 3};
  for (int type : {kUByte, kUShort, kUInt}) {
    SCOPED_TRACE(type);
    Builder b;
    int pos = b.add_positions({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}});
    int idx = b.add_indices(expected, type);
    int mesh = b.add_mesh(json::array({{{"attributes", {{"POSITION", pos}}}, {"indices", idx}}}));
    b.set_scene({b.add_node({{"mesh", mesh}})});
    Scene scene = parse_or_fail(b.glb(), "m.glb", no_weld());
    ASSERT_EQ(scene.parts.size(), 1u);
    EXPECT_EQ(scene.parts[0].indices, expected);
  }
}

TEST(IoGltf, InterleavedStrideAndByteOffset) {
  // Interleaved position + normal, stride 24; the position accessor starts 0 bytes in, the
  // normal accessor 12; the index accessor starts 2 bytes into its view.
  Builder b;
  std::string bytes;
  for (const Vec3& p : kTriangle)
    bytes += le(p.x) + le(p.y) + le(p.z) + le(0.f) + le(0.f) + le(1.f);
  int view = b.add_view(bytes, 24);
  int pos = b.add_accessor(view, kFloat, 3, "VEC3");
  int nrm = b.add_accessor(view, kFloat, 3, "VEC3", 12);
  int idx_view = b.add_view(le(uint16_t{9}) + le(uint16_t{2}) + le(uint16_t{0}) + le(uint16_t{1}));
  int idx = b.add_accessor(idx_view, kUShort, 3, "SCALAR", 2);
  int mesh = b.add_mesh(
      json::array({{{"attributes", {{"POSITION", pos}, {"NORMAL", nrm}}}, {"indices", idx}}}));
  b.set_scene({b.add_node({{"mesh", mesh}})});
  Scene scene = parse_or_fail(b.glb(), "m.glb", no_weld());
  ASSERT_EQ(scene.parts.size(), 1u);
  EXPECT_EQ(scene.parts[0].positions, kTriangle);
  EXPECT_EQ(scene.parts[0].indices, (std::vector<uint32_t>{2, 0, 1}));
  ASSERT_EQ(scene.parts[0].normals.size(), 3u);
  EXPECT_EQ(scene.parts[0].normals[1], (Vec3{0, 0, 1}));
}

TEST(IoGltf, StripsAndFansAreUnrolled) {
  Builder b;
  int pos = b.add_positions({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {2, 1, 0}});
  int strip = b.add_indices({0, 1, 2, 3, 3, 4});  // j=2 (3,2,3)... repeated: dropped
  int fan = b.add_indices({0, 1, 3, 2});
  int mesh = b.add_mesh(json::array({
      {{"attributes", {{"POSITION", pos}}}, {"indices", strip}, {"mode", 5}},
      {{"attributes", {{"POSITION", pos}}}, {"indices", fan}, {"mode", 6}},
  }));
  b.set_scene({b.add_node({{"mesh", mesh}})});
  Scene scene = parse_or_fail(b.glb(), "m.glb", no_weld());
  ASSERT_EQ(scene.parts.size(), 1u);
  // Strip: (0,1,2), (2,1,3), [ (2,3,3) (3,3,4) dropped ]; fan: (0,1,3), (0,3,2).
  EXPECT_EQ(scene.parts[0].indices, (std::vector<uint32_t>{0, 1, 2, 2, 1, 3, 0, 1, 3, 0, 3, 2}));
}

TEST(IoGltf, QuantizedPositions) {
  Builder b;
  std::string shorts = le(int16_t{0}) + le(int16_t{0}) + le(int16_t{0}) + le(int16_t{0}) +
                       le(int16_t{100}) + le(int16_t{-7}) + le(int16_t{0}) + le(int16_t{0});
  int raw = b.add_accessor(b.add_view(shorts), kShort, 2, "VEC3", 2);  // (0,0,0), (100,-7,0)
  std::string ubytes = std::string("\x00\x00\x00\xff\x00\x00\xff\xff\x33", 9);
  int norm = b.add_accessor(b.add_view(ubytes), kUByte, 3, "VEC3", 0, true);
  int mesh = b.add_mesh(json::array({{{"attributes", {{"POSITION", norm}}}}}));
  int mesh2 = b.add_mesh(json::array({{{"attributes", {{"POSITION", raw}}}, {"mode", 0}}}));
  b.root["extensionsRequired"] = {"KHR_mesh_quantization"};
  b.root["extensionsUsed"] = {"KHR_mesh_quantization"};
  b.set_scene({b.add_node({{"mesh", mesh}}), b.add_node({{"mesh", mesh2}})});
  Scene scene = parse_or_fail(b.glb(), "m.glb", no_weld());
  ASSERT_EQ(scene.parts.size(), 1u);  // the points-only node gives no part
  expect_near(scene.parts[0].positions[1], {1, 0, 0});
  expect_near(scene.parts[0].positions[2], {1, 1, 0.2f});

  // The raw shorts, read as a triangle mesh of its own.
  Builder c;
  int s = c.add_accessor(c.add_view(shorts + shorts.substr(0, 6) + "\0\0", 8), kShort, 3, "VEC3");
  int m = c.add_mesh(json::array({{{"attributes", {{"POSITION", s}}}}}));
  c.set_scene({c.add_node({{"mesh", m}})});
  scene = parse_or_fail(c.glb(), "m.glb", no_weld());
  ASSERT_EQ(scene.parts.size(), 1u);
  expect_near(scene.parts[0].positions[1], {100, -7, 0});  // stride 8 over (x, y, z, pad)
}

TEST(IoGltf, SparseAccessors) {
  Builder b;
  int view = b.add_view(le(0.f) + le(0.f) + le(0.f) + le(9.f) + le(9.f) + le(9.f) + le(0.f) +
                        le(1.f) + le(0.f));
  int pos = b.add_accessor(view, kFloat, 3, "VEC3");
  int sparse_idx = b.add_view(le(uint16_t{1}) + std::string(2, '\0'));
  int sparse_val = b.add_view(le(1.f) + le(0.f) + le(0.f));
  b.root["accessors"][pos]["sparse"] = {
      {"count", 1},
      {"indices", {{"bufferView", sparse_idx}, {"componentType", kUShort}}},
      {"values", {{"bufferView", sparse_val}}}};
  // The same replacement on top of an accessor with no bufferView (all zeros).
  int zeros = b.add_accessor(-1, kFloat, 3, "VEC3");
  b.root["accessors"][zeros]["sparse"] = b.root["accessors"][pos]["sparse"];
  int mesh = b.add_mesh(json::array({{{"attributes", {{"POSITION", pos}}}}}));
  int mesh2 = b.add_mesh(json::array({{{"attributes", {{"POSITION", zeros}}}}}));
  b.set_scene(
      {b.add_node({{"name", "a"}, {"mesh", mesh}}), b.add_node({{"name", "b"}, {"mesh", mesh2}})});
  Scene scene = parse_or_fail(b.gltf(), "m.gltf", no_weld());
  ASSERT_EQ(scene.parts.size(), 2u);
  EXPECT_EQ(scene.parts[0].positions, kTriangle);
  EXPECT_EQ(scene.parts[1].positions, (std::vector<Vec3>{{0, 0, 0}, {1, 0, 0}, {0, 0, 0}}));

  b.root["accessors"][pos]["sparse"]["count"] = 4;
  EXPECT_EQ(parse_error(b.glb(), "m.glb"), "m.glb: sparse count 4 is not in 1..3 (accessor 0)");
  b.root["accessors"][pos]["sparse"]["count"] = 1;
  b.bin[b.root["bufferViews"][sparse_idx]["byteOffset"].get<size_t>()] = 3;  // index 3 of 3
  EXPECT_EQ(parse_error(b.glb(), "m.glb"),
            "m.glb: sparse index 3 is out of order or not below the count 3 (accessor 0)");
}

TEST(IoGltf, DefaultSceneAndSceneless) {
  Builder b;
  int pos = b.add_positions(kTriangle);
  int mesh = b.add_mesh(json::array({{{"attributes", {{"POSITION", pos}}}}}));
  int a = b.add_node({{"name", "a"}, {"mesh", mesh}});
  int child = b.add_node({{"name", "child"}, {"mesh", mesh}});
  int c = b.add_node({{"name", "c"}, {"mesh", mesh}, {"children", {child}}});
  b.root["scenes"] = json::array({{{"nodes", {a}}}, {{"nodes", {c}}}});
  b.root["scene"] = 1;
  Scene scene = parse_or_fail(b.glb(), "m.glb");
  ASSERT_EQ(scene.parts.size(), 2u);
  EXPECT_EQ(scene.parts[0].name, "m/c");
  EXPECT_EQ(scene.parts[1].name, "m/child");

  b.root.erase("scene");  // no default: scene 0
  EXPECT_EQ(parse_or_fail(b.glb(), "m.glb").parts.size(), 1u);
  b.root.erase("scenes");  // no scenes: every root node (a and c, with c's child)
  EXPECT_EQ(parse_or_fail(b.glb(), "m.glb").parts.size(), 3u);
  b.root["scenes"] = json::array({{{"nodes", {a}}}});
  b.root["scene"] = 4;
  EXPECT_EQ(parse_error(b.glb(), "m.glb"), "m.glb: the default scene 4 does not exist (scene)");
}

TEST(IoGltf, ImagesAreNeverDecoded) {
  Builder b = single_triangle();
  // Not an image at all: a decoder would fail; the reader must not even try.
  b.root["images"] = json::array({{{"uri", "data:image/png;base64,AAAAAAAA"}},
                                  {{"bufferView", 0}, {"mimeType", "image/png"}}});
  EXPECT_EQ(parse_or_fail(b.glb(), "m.glb").parts.size(), 1u);
  EXPECT_EQ(parse_or_fail(b.gltf(), "m.gltf").parts.size(), 1u);
}

// ---- errors ----------------------------------------------------------------------------------

TEST(IoGltf, IndexOutOfRange) {
  Builder b;
  int pos = b.add_positions(kTriangle);
  int idx = b.add_indices({0, 1, 7});
  int mesh = b.add_mesh(json::array({{{"attributes", {{"POSITION", pos}}}, {"indices", idx}}}));
  b.set_scene({b.add_node({{"mesh", mesh}})});
  EXPECT_EQ(parse_error(b.glb(), "m.glb"),
            "m.glb: index 2 is 7, but POSITION has 3 vertices (accessor 1)");
}

TEST(IoGltf, AccessorOutOfBounds) {
  Builder b = single_triangle();
  b.root["accessors"][0]["count"] = 4;
  EXPECT_EQ(parse_error(b.glb(), "m.glb"),
            "m.glb: 4 elements of 12 bytes every 12 from byte 0 overrun bufferView 0 of 36 bytes "
            "(accessor 0)");
  b = single_triangle();
  b.root["accessors"][0]["byteOffset"] = 4;
  EXPECT_NE(parse_error(b.glb(), "m.glb").find("from byte 4 overrun bufferView 0"),
            std::string::npos);
  b = single_triangle();
  b.root["bufferViews"][0]["byteLength"] = 4000;
  EXPECT_EQ(parse_error(b.glb(), "m.glb"),
            "m.glb: bytes 0 + 4000 overrun buffer 0 of 42 bytes (bufferView 0)");
  b = single_triangle();
  b.root["bufferViews"][0]["byteStride"] = 8;
  EXPECT_EQ(parse_error(b.glb(), "m.glb"),
            "m.glb: byteStride 8 is less than the element size 12 (bufferView 0)");
  b = single_triangle();
  b.root["accessors"][0]["bufferView"] = 9;
  EXPECT_EQ(parse_error(b.glb(), "m.glb"), "m.glb: bufferView 9 does not exist (accessor 0)");
  b = single_triangle();
  b.root["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 5;
  EXPECT_EQ(parse_error(b.glb(), "m.glb"),
            "m.glb: POSITION uses accessor 5, which does not exist (accessor 5)");
  b = single_triangle();
  b.root["accessors"][0]["type"] = "VEC2";
  EXPECT_EQ(parse_error(b.glb(), "m.glb"), "m.glb: POSITION must be VEC3 (accessor 0)");
  b = single_triangle();
  b.root["accessors"][1]["componentType"] = kShort;
  EXPECT_EQ(parse_error(b.glb(), "m.glb"),
            "m.glb: componentType 5122 is not allowed for indices (accessor 1)");
  b = single_triangle();
  b.root["accessors"][1]["count"] = 2;
  EXPECT_EQ(parse_error(b.glb(), "m.glb"),
            "m.glb: TRIANGLES with 2 vertices, not a multiple of 3 (mesh 0 primitive 0)");
  b = single_triangle();
  b.root["accessors"][0].erase("bufferView");
  b.root["accessors"][0]["count"] = 4000000000u;
  EXPECT_EQ(parse_error(b.glb(), "m.glb"),
            "m.glb: count 4000000000 without a bufferView is more than the file's size allows "
            "(accessor 0)");
  b = single_triangle();
  b.root["meshes"][0]["primitives"][0]["mode"] = 9;
  EXPECT_EQ(parse_error(b.glb(), "m.glb"),
            "m.glb: mode 9 is not a glTF primitive mode (mesh 0 primitive 0)");
}

TEST(IoGltf, NonFinitePositions) {
  Builder b;
  int pos = b.add_positions({{0, 0, 0}, {NAN, 0, 0}, {0, 1, 0}});
  int mesh = b.add_mesh(json::array({{{"attributes", {{"POSITION", pos}}}}}));
  b.set_scene({b.add_node({{"mesh", mesh}})});
  EXPECT_EQ(parse_error(b.glb(), "m.glb"),
            "m.glb: vertex 1 has a NaN or infinite coordinate (accessor 0)");
  // Finite in the file, infinite once scaled.
  b = single_triangle({{"scale", {1e39, 1e39, 1e39}}});
  EXPECT_EQ(parse_error(b.glb(), "m.glb"),
            "m.glb: vertex 1 has a NaN or infinite coordinate (accessor 0)");
}

TEST(IoGltf, BadHierarchies) {
  Builder b = single_triangle();
  b.root["nodes"][0]["children"] = {0};
  EXPECT_EQ(parse_error(b.glb(), "m.glb"),
            "m.glb: node 0 is reached twice: the node hierarchy must be a tree (node 0)");
  b = single_triangle();
  b.root["nodes"][0]["children"] = {3};
  EXPECT_EQ(parse_error(b.glb(), "m.glb"), "m.glb: node 3 does not exist (node 0)");
  b = single_triangle();
  b.root["nodes"][0]["mesh"] = 2;
  EXPECT_EQ(parse_error(b.glb(), "m.glb"), "m.glb: mesh 2 does not exist (node 0)");
}

TEST(IoGltf, JsonGarbage) {
  for (const char* text : {"{", "{\"asset\": ", "not json at all", "[1, 2, 3]",
                           "{\"asset\": {\"version\": \"2.0\"}, \"nodes\": [5]}"}) {
    SCOPED_TRACE(text);
    Status status = read_status(text, "m.gltf");
    EXPECT_EQ(status.code(), ErrorCode::kInvalidData);
    EXPECT_EQ(status.message().rfind("m.gltf: invalid glTF: ", 0), 0u) << status.message();
  }
  EXPECT_EQ(parse_error("{\"asset\": {\"generator\": \"x\"}}", "m.gltf")
                .rfind("m.gltf: invalid glTF: ", 0),
            0u);
  // Garbage inside a GLB's JSON chunk is reported at the chunk.
  std::string glb = Builder::make_glb("{\"asset\": [}", "");
  EXPECT_NE(parse_error(glb, "m.glb").find("(byte 20)"), std::string::npos);
  // An empty scene is valid glTF, but holds no triangles.
  EXPECT_EQ(parse_error("{\"asset\": {\"version\": \"2.0\"}}", "m.gltf"),
            "m.gltf: the file holds no triangles");
}

TEST(IoGltf, DeepNestingIsRefusedBeforeParsing) {
  std::string deep = "{\"asset\": {\"version\": \"2.0\"}, \"extras\": " + std::string(100000, '[') +
                     std::string(100000, ']') + "}";
  EXPECT_EQ(parse_error(deep, "m.gltf"), "m.gltf: JSON nested deeper than 128 levels (byte 167)");
  // Brackets inside strings do not count.
  Builder b = single_triangle({{"name", std::string(1000, '[') + "\\\"" + std::string(10, '{')}});
  EXPECT_EQ(parse_or_fail(b.glb(), "m.glb").parts.size(), 1u);
}

TEST(IoGltf, VersionsAndRequiredExtensions) {
  Builder b = single_triangle();
  b.root["asset"]["version"] = "1.0";
  Status status = read_status(b.glb(), "m.glb");
  EXPECT_EQ(status.code(), ErrorCode::kUnsupported);
  EXPECT_EQ(status.message(), "m.glb: glTF version '1.0' is not supported (only 2.x) (asset)");
  for (const char* ext :
       {"KHR_draco_mesh_compression", "EXT_meshopt_compression", "VENDOR_unknown"}) {
    b = single_triangle();
    b.root["extensionsRequired"] = {"KHR_materials_emissive_strength", ext};
    status = read_status(b.glb(), "m.glb");
    EXPECT_EQ(status.code(), ErrorCode::kUnsupported);
    EXPECT_EQ(status.message(),
              std::string("m.glb: requires ") + ext + ", which osteon does not read (extensionsRequired)");
  }
  b = single_triangle();  // used, not required: the uncompressed fallback is read
  b.root["extensionsUsed"] = {"KHR_draco_mesh_compression"};
  EXPECT_EQ(parse_or_fail(b.glb(), "m.glb").parts.size(), 1u);
}

// EXT_mesh_gpu_instancing: one part per instance, T * R * S before the node's matrix, the winding
// reversed where the product mirrors; named "<node>#<i>", or from osteon export's extras.
TEST(IoGltf, GpuInstancesBecomeParts) {
  Builder b;
  int pos = b.add_positions(kTriangle);
  int idx = b.add_indices({0, 1, 2});
  int mesh = b.add_mesh(json::array({{{"attributes", {{"POSITION", pos}}}, {"indices", idx}}}));
  std::string t = le(10.0f) + le(0.0f) + le(0.0f) + le(0.0f) + le(20.0f) + le(0.0f);
  std::string sc = le(1.0f) + le(1.0f) + le(1.0f) + le(-2.0f) + le(1.0f) + le(1.0f);
  int translation = b.add_accessor(b.add_view(t), kFloat, 2, "VEC3");
  int scale = b.add_accessor(b.add_view(sc), kFloat, 2, "VEC3");
  json node = {{"name", "rib"},
               {"mesh", mesh},
               {"translation", {0, 0, 5}},
               {"extensions",
                {{"EXT_mesh_gpu_instancing",
                  {{"attributes", {{"TRANSLATION", translation}, {"SCALE", scale}}}}}}}};
  b.set_scene({b.add_node(node)});
  b.root["extensionsUsed"] = {"EXT_mesh_gpu_instancing"};
  b.root["extensionsRequired"] = {"EXT_mesh_gpu_instancing"};
  Scene scene = parse_or_fail(b.glb(), "m.glb", no_weld());
  ASSERT_EQ(scene.parts.size(), 2u);
  EXPECT_EQ(scene.parts[0].name, "m/rib#0");
  EXPECT_EQ(scene.parts[1].name, "m/rib#1");
  expect_near(scene.parts[0].positions[1], {11, 0, 5});
  expect_near(scene.parts[1].positions[1], {-2, 20, 5});
  EXPECT_GT(face_normal(scene.parts[0], 0).z, 0);
  EXPECT_GT(face_normal(scene.parts[1], 0).z, 0);  // mirrored: winding reversed, still +z

  b.root["nodes"][0]["extras"] = {
      {"osteon", {{"instances", json::array({{{"name", "rib_l1"}}, {{"name", "rib_r1"}}})}}}};
  scene = parse_or_fail(b.glb(), "m.glb", no_weld());
  ASSERT_EQ(scene.parts.size(), 2u);
  EXPECT_EQ(scene.parts[0].name, "m/rib_l1");
  EXPECT_EQ(scene.parts[1].name, "m/rib_r1");

  b.root["nodes"][0]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"]["TRANSLATION"] =
      b.add_accessor(b.add_view(le(1.0f) + le(2.0f) + le(3.0f)), kFloat, 1, "VEC3");
  EXPECT_EQ(parse_error(b.glb(), "m.glb"),
            "m.glb: SCALE has 2 instances, not 1 (node 0 EXT_mesh_gpu_instancing)");
}

TEST(IoGltf, GlbContainerErrors) {
  const std::string good = single_triangle().glb();
  auto with = [&](size_t at, uint32_t value) {
    std::string s = good;
    std::memcpy(s.data() + at, &value, 4);
    return s;
  };
  EXPECT_EQ(parse_error(with(4, 1), "m.glb"),
            "m.glb: GLB version 1 is not supported (only 2) (byte 4)");
  EXPECT_EQ(parse_error(with(8, static_cast<uint32_t>(good.size() + 1)), "m.glb"),
            "m.glb: the GLB header declares " + std::to_string(good.size() + 1) +
                " bytes, the file has " + std::to_string(good.size()) + " (byte 8)");
  EXPECT_EQ(parse_error(with(16, 0x12345678), "m.glb"),
            "m.glb: the first GLB chunk is not JSON (byte 16)");
  EXPECT_NE(parse_error(with(12, 0xfffffff0u), "m.glb").find("the JSON chunk declares 4294967280"),
            std::string::npos);
  // The BIN chunk claiming its own header's 8 bytes too: tinygltf 2.7.0 would read past the end.
  uint32_t json_length = 0;
  std::memcpy(&json_length, good.data() + 12, 4);
  size_t bin_at = 20 + json_length;
  uint32_t bin_length = static_cast<uint32_t>(good.size() - bin_at);
  EXPECT_EQ(parse_error(with(bin_at, bin_length), "m.glb"),
            "m.glb: the BIN chunk declares " + std::to_string(bin_length) + " bytes, room for " +
                std::to_string(bin_length - 8) + " (byte " + std::to_string(bin_at) + ")");
  EXPECT_EQ(parse_error(with(bin_at + 4, 0x4e4f534a), "m.glb"),
            "m.glb: the second GLB chunk is not BIN (byte " + std::to_string(bin_at + 4) + ")");
  EXPECT_NE(parse_error(with(bin_at, 6), "m.glb").find("is not a positive multiple of 4"),
            std::string::npos);
}

TEST(IoGltf, TruncatedGlbFailsAtEveryCut) {
  const std::string good = single_triangle().glb();
  for (size_t cut = 0; cut < good.size(); ++cut) {
    std::string bytes = good.substr(0, cut);
    auto result = read_memory(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), "m.glb",
                              Format::kGlb);
    EXPECT_FALSE(result.ok()) << "cut at " << cut;
  }
  // Cut, with the header's length patched to match: tinygltf sees a consistent but short GLB.
  for (size_t cut = 12; cut < good.size(); cut += 4) {
    std::string bytes = good.substr(0, cut);
    uint32_t length = static_cast<uint32_t>(cut);
    std::memcpy(bytes.data() + 8, &length, 4);
    auto result = read_memory(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), "m.glb",
                              Format::kGlb);
    EXPECT_FALSE(result.ok()) << "cut at " << cut;
  }
}

TEST(IoGltf, FlippedBitsNeverCrash) {
  const std::string good = single_triangle({{"scale", {2, 2, 2}}}).glb();
  for (size_t i = 0; i < good.size(); ++i) {
    for (int bit : {0, 5, 7}) {
      std::string bytes = good;
      bytes[i] = static_cast<char>(bytes[i] ^ (1 << bit));
      auto result =
          read_memory(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), "m.glb");
      if (!result.ok()) continue;
      for (const Mesh& part : result->parts) {
        for (uint32_t index : part.indices) ASSERT_LT(index, part.positions.size());
      }
    }
  }
}

// ---- external files ------------------------------------------------------------------------

TEST(IoGltf, ExternalBuffers) {
  Builder b = single_triangle();
  json j = b.with_buffer(false);
  j["buffers"][0]["uri"] = "tri%20angle.bin";  // URI-encoded
  std::string dir = test::scratch_dir();
  test::write_bytes(dir + "/m.gltf", j.dump());
  test::write_bytes(dir + "/tri angle.bin", b.bin);

  auto result = read_path(dir + "/m.gltf");
  ASSERT_TRUE(result.ok()) << result.status().message();
  ASSERT_EQ(result->parts.size(), 1u);
  EXPECT_EQ(result->parts[0].triangle_count(), 1u);

  // From memory there is no folder: the external buffer is refused, not looked up in the cwd.
  std::string text = j.dump();
  Status status = read_status(text, "m.gltf");
  EXPECT_EQ(status.code(), ErrorCode::kUnsupported);
  EXPECT_EQ(status.message(),
            "m.gltf: external file 'tri angle.bin': a glTF read from memory may only use embedded "
            "buffers (data: URIs or the GLB BIN chunk)");

  // Nothing outside the glTF's folder is read, whatever the URI says.
  std::string inner = dir + "/inner";
  std::filesystem::create_directories(inner);
  for (const std::string& uri : {std::string("../tri angle.bin"), dir + "/tri angle.bin",
                                 std::string("missing.bin"), std::string(".")}) {
    SCOPED_TRACE(uri);
    j["buffers"][0]["uri"] = uri;
    test::write_bytes(inner + "/m.gltf", j.dump());
    auto refused = read_path(inner + "/m.gltf");
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.status().code(), ErrorCode::kIoError);
    EXPECT_NE(refused.status().message().find(
                  "is missing, not a regular file, or outside the glTF's folder"),
              std::string::npos)
        << refused.status().message();
  }
}

// ---- real data -----------------------------------------------------------------------------

std::map<std::string, std::map<std::string, std::string>> read_stats(const std::string& path) {
  std::map<std::string, std::map<std::string, std::string>> rows;
  std::ifstream in(path);
  std::string line;
  std::vector<std::string> header;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) cells.push_back(cell);
    if (header.empty()) {
      header = cells;
      continue;
    }
    auto& row = rows[cells[0]];
    for (size_t i = 0; i < cells.size() && i < header.size(); ++i) row[header[i]] = cells[i];
  }
  return rows;
}

TEST(IoGltf, RealBodyPartsFilesMatchStats) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  auto stats = read_stats(data + "/STATS.csv");
  const std::string folder = "aHer-dev__3DAnatomy/models/bones";
  size_t files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(data + "/" + folder)) {
    if (entry.path().extension() != ".glb") continue;
    std::string key = folder + "/" + entry.path().filename().string();
    SCOPED_TRACE(key);
    ASSERT_TRUE(stats.count(key));
    const auto& row = stats[key];
    std::vector<uint8_t> bytes = test::read_bytes(entry.path().string());
    auto result = read_memory(bytes.data(), bytes.size(), entry.path().string());
    ASSERT_TRUE(result.ok()) << result.status().message();
    ASSERT_EQ(result->parts.size(), 1u);
    const Mesh& mesh = result->parts[0];
    EXPECT_EQ(mesh.stored_vertices, std::stoul(row.at("stored_vertices")));
    EXPECT_EQ(mesh.vertex_count(), std::stoul(row.at("welded_vertices")));
    EXPECT_EQ(mesh.triangle_count(), std::stoul(row.at("triangles")));
    EXPECT_EQ(mesh.normals.size(), mesh.vertex_count());
    // STATS.csv measured the mesh in its local frame; every node here turns it +90 degrees about
    // x, (x, y, z) -> (x, -z, y), and our box is taken after the node transform.
    Aabb box = bounding_box(mesh);
    EXPECT_NEAR(box.max.x - box.min.x, std::stod(row.at("bbox_x")), 2e-3);
    EXPECT_NEAR(box.max.y - box.min.y, std::stod(row.at("bbox_z")), 2e-3);
    EXPECT_NEAR(box.max.z - box.min.z, std::stod(row.at("bbox_y")), 2e-3);
    ++files;
  }
  EXPECT_EQ(files, 235u);
}


// ---- meshopt-compressed views (gltfpack -cc, gltf-transform meshopt) ----------------------------

/// A grid of `n` x `n` vertices (two triangles a cell) as a GLB whose position and index views are
/// compressed with meshoptimizer (EXT_meshopt_compression, or `extension`), each view's own buffer
/// a fallback with no data, as gltfpack writes it. `edit` may break the compressed views' JSON.
std::string meshopt_grid(int n, std::vector<Vec3>* points, std::vector<uint32_t>* indices,
                         const std::string& extension = "EXT_meshopt_compression",
                         const std::function<void(json&)>& edit = nullptr) {
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) points->push_back({float(x), float(y), float((x * y) % 3)});
  }
  for (int y = 0; y + 1 < n; ++y) {
    for (int x = 0; x + 1 < n; ++x) {
      const uint32_t v = uint32_t(y * n + x);
      for (uint32_t i : {v, v + 1, v + uint32_t(n), v + 1, v + uint32_t(n) + 1, v + uint32_t(n)}) {
        indices->push_back(i);
      }
    }
  }
  std::vector<uint8_t> vb(meshopt_encodeVertexBufferBound(points->size(), sizeof(Vec3)));
  vb.resize(meshopt_encodeVertexBuffer(vb.data(), vb.size(), points->data(), points->size(),
                                       sizeof(Vec3)));
  std::vector<uint8_t> ib(meshopt_encodeIndexBufferBound(indices->size(), points->size()));
  ib.resize(meshopt_encodeIndexBuffer(ib.data(), ib.size(), indices->data(), indices->size()));
  std::string bin(vb.begin(), vb.end());
  while (bin.size() % 4 != 0) bin += '\0';
  const size_t ib_at = bin.size();
  bin.append(ib.begin(), ib.end());
  json compressed_v = {{"buffer", 0}, {"byteOffset", 0}, {"byteLength", vb.size()},
                       {"byteStride", 12}, {"count", points->size()}, {"mode", "ATTRIBUTES"}};
  json compressed_i = {{"buffer", 0}, {"byteOffset", ib_at}, {"byteLength", ib.size()},
                       {"byteStride", 4}, {"count", indices->size()}, {"mode", "TRIANGLES"}};
  json root = {
      {"asset", {{"version", "2.0"}}},
      {"extensionsUsed", {extension}},
      {"extensionsRequired", {extension}},
      {"buffers",
       {{{"byteLength", bin.size()}},
        {{"byteLength", 12 * points->size() + 4 * indices->size()},
         {"extensions", {{extension, {{"fallback", true}}}}}}}},
      {"bufferViews",
       {{{"buffer", 1}, {"byteOffset", 0}, {"byteLength", 12 * points->size()}, {"byteStride", 12},
         {"extensions", {{extension, compressed_v}}}},
        {{"buffer", 1}, {"byteOffset", 12 * points->size()}, {"byteLength", 4 * indices->size()},
         {"extensions", {{extension, compressed_i}}}}}},
      {"accessors",
       {{{"bufferView", 0}, {"componentType", kFloat}, {"count", points->size()}, {"type", "VEC3"}},
        {{"bufferView", 1}, {"componentType", kUInt}, {"count", indices->size()},
         {"type", "SCALAR"}}}},
      {"meshes", {{{"primitives", {{{"attributes", {{"POSITION", 0}}}, {"indices", 1}}}}}}},
      {"nodes", {{{"mesh", 0}, {"name", "grid"}}}},
      {"scenes", {{{"nodes", {0}}}}},
      {"scene", 0}};
  if (edit) edit(root);
  return Builder::make_glb(root.dump(), bin);
}

TEST(IoGltf, MeshoptCompressedViewsAreDecoded) {
  for (const char* extension : {"EXT_meshopt_compression", "KHR_meshopt_compression"}) {
    std::vector<Vec3> points;
    std::vector<uint32_t> indices;
    const std::string glb = meshopt_grid(9, &points, &indices, extension);
    Scene scene = parse_or_fail(glb, "grid.glb", no_weld());
    ASSERT_EQ(scene.parts.size(), 1u) << extension;
    const Mesh& mesh = scene.parts[0];
    EXPECT_EQ(mesh.name, "grid");
    ASSERT_EQ(mesh.indices.size(), indices.size());
    ASSERT_EQ(mesh.positions.size(), points.size());
    // The index codec may rotate a triangle's corners (never its winding): compare each triangle
    // from its smallest corner on.
    auto triangles = [](const std::vector<Vec3>& at, const std::vector<uint32_t>& ids) {
      std::multiset<std::array<float, 9>> out;
      for (size_t t = 0; t + 2 < ids.size(); t += 3) {
        std::array<std::array<float, 3>, 3> c;
        for (int k = 0; k < 3; ++k) c[k] = {at[ids[t + k]].x, at[ids[t + k]].y, at[ids[t + k]].z};
        const int first = int(std::min_element(c.begin(), c.end()) - c.begin());
        std::array<float, 9> key;
        for (int k = 0; k < 3; ++k) {
          for (int d = 0; d < 3; ++d) key[3 * k + d] = c[(first + k) % 3][d];
        }
        out.insert(key);
      }
      return out;
    };
    EXPECT_EQ(triangles(mesh.positions, mesh.indices), triangles(points, indices)) << extension;
  }
}

TEST(IoGltf, BrokenMeshoptViewsAreRefusedByField) {
  std::vector<Vec3> p;
  std::vector<uint32_t> i;
  auto error_of = [&](const std::function<void(json&)>& edit,
                      const std::string& extension = "EXT_meshopt_compression") {
    p.clear();
    i.clear();
    return read_status(meshopt_grid(9, &p, &i, extension, edit), "grid.glb");
  };
  auto ext = [](json& root, int view) -> json& {
    return root["bufferViews"][view]["extensions"]["EXT_meshopt_compression"];
  };
  // A huge declared count: refused before any allocation.
  Status huge = error_of([&](json& r) { ext(r, 0)["count"] = 4000000000ull; });
  EXPECT_EQ(huge.code(), ErrorCode::kInvalidData);
  EXPECT_NE(huge.message().find("bufferViews[0]"), std::string::npos) << huge.message();
  EXPECT_NE(huge.message().find("grid.glb"), std::string::npos);
  // Compressed bytes beyond the BIN chunk.
  Status outside = error_of([&](json& r) { ext(r, 1)["byteOffset"] = 1u << 20; });
  EXPECT_NE(outside.message().find("bufferViews[1]"), std::string::npos) << outside.message();
  EXPECT_NE(outside.message().find("beyond the BIN chunk"), std::string::npos);
  // A stride the index decoder does not take; an unknown mode; truncated data.
  EXPECT_NE(error_of([&](json& r) { ext(r, 1)["byteStride"] = 3; }).message().find("byteStride 3"),
            std::string::npos);
  EXPECT_NE(error_of([&](json& r) { ext(r, 0)["mode"] = "POINTS"; }).message().find("POINTS"),
            std::string::npos);
  Status cut = error_of([&](json& r) { ext(r, 0)["byteLength"] = 9; });
  EXPECT_EQ(cut.code(), ErrorCode::kInvalidData);
  EXPECT_NE(cut.message().find("does not decode"), std::string::npos) << cut.message();
  // The newer vertex codec (version 1, KHR_meshopt_compression's), which meshoptimizer 0.18 does
  // not decode: refused by name. The vertex data is the first thing in the BIN chunk.
  p.clear();
  i.clear();
  std::string glb = meshopt_grid(9, &p, &i, "KHR_meshopt_compression");
  uint32_t json_length = 0;
  std::memcpy(&json_length, glb.data() + 12, 4);
  glb[20 + json_length + 8] = char(0xa1);
  Status v1 = read_status(glb, "cz.glb");
  EXPECT_EQ(v1.code(), ErrorCode::kUnsupported);
  EXPECT_NE(v1.message().find("meshopt vertex codec version 1"), std::string::npos) << v1.message();
}

// ---- Draco-compressed primitives (gltf-transform draco, Blender) --------------------------------

/// The grid of meshopt_grid as a GLB whose one primitive is Draco-compressed (14-bit positions),
/// its accessors without bufferViews, as gltf-transform writes it.
std::string draco_grid(int n, std::vector<Vec3>* points, std::vector<uint32_t>* indices) {
  meshopt_grid(n, points, indices);
  draco::TriangleSoupMeshBuilder builder;
  builder.Start(int(indices->size() / 3));
  const int position = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
  for (size_t t = 0; t < indices->size() / 3; ++t) {
    builder.SetAttributeValuesForFace(position, draco::FaceIndex(uint32_t(t)),
                                      &(*points)[(*indices)[3 * t]],
                                      &(*points)[(*indices)[3 * t + 1]],
                                      &(*points)[(*indices)[3 * t + 2]]);
  }
  std::unique_ptr<draco::Mesh> mesh = builder.Finalize();
  draco::Encoder encoder;
  encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, 14);
  draco::EncoderBuffer buffer;
  EXPECT_TRUE(encoder.EncodeMeshToBuffer(*mesh, &buffer).ok());
  const std::string bin(buffer.data(), buffer.size());
  const uint32_t unique_id = mesh->attribute(position)->unique_id();
  json root = {
      {"asset", {{"version", "2.0"}}},
      {"extensionsUsed", {"KHR_draco_mesh_compression"}},
      {"extensionsRequired", {"KHR_draco_mesh_compression"}},
      {"buffers", {{{"byteLength", (bin.size() + 3) / 4 * 4}}}},
      {"bufferViews", {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", bin.size()}}}},
      {"accessors",
       {{{"componentType", kFloat}, {"count", mesh->num_points()}, {"type", "VEC3"}},
        {{"componentType", kUInt}, {"count", indices->size()}, {"type", "SCALAR"}}}},
      {"meshes",
       {{{"primitives",
          {{{"attributes", {{"POSITION", 0}}},
            {"indices", 1},
            {"extensions",
             {{"KHR_draco_mesh_compression",
               {{"bufferView", 0}, {"attributes", {{"POSITION", unique_id}}}}}}}}}}}}},
      {"nodes", {{{"mesh", 0}, {"name", "grid"}}}},
      {"scenes", {{{"nodes", {0}}}}},
      {"scene", 0}};
  return Builder::make_glb(root.dump(), bin);
}

TEST(IoGltf, DracoPrimitivesAreDecoded) {
  std::vector<Vec3> points;
  std::vector<uint32_t> indices;
  std::string glb = draco_grid(9, &points, &indices);
  Scene scene = parse_or_fail(glb, "draco.glb");
  ASSERT_EQ(scene.parts.size(), 1u);
  const Mesh& mesh = scene.parts[0];
  EXPECT_EQ(mesh.name, "draco");  // one part: named by the file
  EXPECT_EQ(mesh.triangle_count(), indices.size() / 3);
  EXPECT_EQ(mesh.positions.size(), points.size());
  // Every decoded vertex within 14-bit quantization of an input vertex.
  const double step = 8.0 / ((1 << 14) - 1);
  for (const Vec3& p : mesh.positions) {
    double best = 1e9;
    for (const Vec3& q : points) best = std::min(best, double(length(to_double(p - q))));
    EXPECT_LE(best, step) << p.x << " " << p.y << " " << p.z;
  }
  // A corrupt stream fails naming the primitive; it does not crash.
  uint32_t json_length = 0;
  std::memcpy(&json_length, glb.data() + 12, 4);
  for (size_t i = 20 + json_length + 8 + 2; i < glb.size(); i += 5) glb[i] = char(glb[i] ^ 0x5a);
  Status bad = read_status(glb, "draco.glb");
  EXPECT_FALSE(bad.ok());
  EXPECT_NE(bad.message().find("draco.glb"), std::string::npos) << bad.message();
}

TEST(IoGltf, UnreadableRequiredExtensionsAreRefusedByName) {
  // Draco in a .gltf (decoded in GLBs only): refused by the extension's name first.
  Builder b = single_triangle();
  b.root["extensionsUsed"] = {"KHR_draco_mesh_compression"};
  b.root["extensionsRequired"] = {"KHR_draco_mesh_compression"};
  b.root["accessors"][0].erase("bufferView");
  Status s = read_status(b.gltf(), "draco.gltf");
  EXPECT_EQ(s.code(), ErrorCode::kUnsupported);
  EXPECT_NE(s.message().find("requires KHR_draco_mesh_compression, which osteon does not read"),
            std::string::npos)
      << s.message();
  Builder c = single_triangle();
  c.root["extensionsRequired"] = {"EXT_foo"};
  EXPECT_NE(read_status(c.glb(), "foo.glb").message().find("requires EXT_foo"),
            std::string::npos);
}

}  // namespace io_gltf_test
}  // namespace
}  // namespace osteon

namespace osteon {
namespace {
namespace io_gltf_test {

// What the web pipelines write: the phantom's skull (320 triangles) through gltfpack 1.3 (-cc:
// EXT_meshopt_compression; -cz: KHR_meshopt_compression's newer vertex codec) and gltf-transform
// 4.5 (draco), kept as fuzz seeds.
TEST(IoGltf, WhatGltfpackAndGltfTransformWrite) {
  const std::string seeds = std::string(OSTEON_SOURCE_DIR) + "/fuzz/corpus/glb/";
  for (const char* name : {"seed-phantom-skull-gltfpack-cc.glb",
                           "seed-phantom-skull-gltf-transform-draco.glb"}) {
    Result<Scene> scene = read_path(seeds + name);
    ASSERT_TRUE(scene.ok()) << name << ": " << scene.status().message();
    ASSERT_EQ(scene->parts.size(), 1u) << name;
    EXPECT_EQ(scene->parts[0].triangle_count(), 320u) << name;
    EXPECT_EQ(scene->parts[0].positions.size(), 162u) << name;
  }
  Result<Scene> cz = read_path(seeds + "seed-phantom-skull-gltfpack-cz.glb");
  ASSERT_FALSE(cz.ok());
  EXPECT_EQ(cz.status().code(), ErrorCode::kUnsupported);
  EXPECT_NE(cz.status().message().find("meshopt vertex codec version 1"), std::string::npos)
      << cz.status().message();
}

}  // namespace io_gltf_test
}  // namespace
}  // namespace osteon
