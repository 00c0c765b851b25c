// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <bit>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "fixtures.hpp"
#include "osteon/io.hpp"
#include "support/phantom.hpp"

namespace osteon {
namespace {
namespace io_write_test {

namespace fs = std::filesystem;
using test::canonical_triangles;
using test::mesh_categories;
using test::read_bytes;
using test::scratch_dir;

std::vector<std::string> names_in(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.push_back(entry.path().filename());
  std::sort(names.begin(), names.end());
  return names;
}

std::string text_of(const std::string& path) {
  std::vector<uint8_t> bytes = read_bytes(path);
  return std::string(bytes.begin(), bytes.end());
}

Mesh read_one(const std::string& path, bool weld) {
  ReadOptions options;
  options.weld = weld;
  auto scene = read_path(path, options);
  EXPECT_TRUE(scene.ok()) << scene.status().message();
  if (!scene.ok()) return {};
  EXPECT_EQ(scene->parts.size(), 1u) << path;
  return scene->parts.empty() ? Mesh() : scene->parts[0];
}

uint32_t load_u32(const std::vector<uint8_t>& bytes, size_t offset) {
  uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | bytes[offset + i];
  return v;
}
float load_f32(const std::vector<uint8_t>& bytes, size_t offset) {
  return std::bit_cast<float>(load_u32(bytes, offset));
}

/// The position of every triangle corner, in triangle order: equal for two meshes that hold the
/// same triangles in the same order, whatever their vertex numbering (the OBJ reader numbers each
/// part's vertices in the order its faces first use them).
std::vector<Vec3> corner_positions(const Mesh& mesh) {
  std::vector<Vec3> out;
  for (uint32_t i : mesh.indices) out.push_back(mesh.positions[i]);
  return out;
}
std::vector<Vec3> corner_normals(const Mesh& mesh) {
  std::vector<Vec3> out;
  if (mesh.normals.empty()) return out;
  for (uint32_t i : mesh.indices) out.push_back(mesh.normals[i]);
  return out;
}

/// Expects `back` (read from a file `mesh` was written to) to hold exactly `mesh`: the same
/// vertices and triangles, bit for bit. PLY keeps the vertex numbering too; OBJ renumbers.
void expect_same_mesh(const Mesh& back, const Mesh& mesh, bool same_numbering) {
  EXPECT_EQ(back.vertex_count(), mesh.vertex_count());
  EXPECT_EQ(back.triangle_count(), mesh.triangle_count());
  EXPECT_EQ(corner_positions(back), corner_positions(mesh));
  EXPECT_EQ(corner_normals(back), corner_normals(mesh));
  if (same_numbering) {
    EXPECT_EQ(back.positions, mesh.positions);
    EXPECT_EQ(back.indices, mesh.indices);
    EXPECT_EQ(back.normals, mesh.normals);
  }
}

/// The number of distinct positions a mesh's triangles use (what welding an STL soup gives).
size_t distinct_referenced_positions(const Mesh& mesh) {
  std::vector<std::array<float, 3>> used;
  for (uint32_t i : mesh.indices) {
    const Vec3& p = mesh.positions[i];
    used.push_back({p.x + 0.0f, p.y + 0.0f, p.z + 0.0f});  // -0 welds with +0
  }
  std::sort(used.begin(), used.end());
  return size_t(std::unique(used.begin(), used.end()) - used.begin());
}

/// Tricky floats that must survive a text round trip bit for bit.
Mesh tricky_float_mesh() {
  Mesh mesh;
  std::vector<float> values = {0.1f,
                               -0.0f,
                               1.0f / 3.0f,
                               1e-7f,
                               16777217.0f,
                               std::numeric_limits<float>::min(),
                               std::numeric_limits<float>::denorm_min(),
                               std::numeric_limits<float>::max(),
                               -std::numeric_limits<float>::max(),
                               std::nextafter(1.0f, 2.0f),
                               123456.789f,
                               -2.5e-30f};
  std::mt19937 rng(7);
  for (int i = 0; i < 300; ++i) {
    uint32_t bits = rng();
    float f = std::bit_cast<float>(bits);
    if (std::isfinite(f)) values.push_back(f);
  }
  while (values.size() % 9 != 0) values.push_back(0.5f);
  for (size_t i = 0; i < values.size(); i += 3)
    mesh.positions.push_back({values[i], values[i + 1], values[i + 2]});
  for (uint32_t v = 0; v + 2 < mesh.positions.size(); v += 3)
    mesh.indices.insert(mesh.indices.end(), {v, v + 1, v + 2});
  return mesh;
}

Mesh with_normals(Mesh mesh) {
  mesh.normals.clear();
  for (const Vec3& p : mesh.positions) {
    float length = std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
    mesh.normals.push_back(length > 0 ? Vec3{p.x / length, p.y / length, p.z / length}
                                      : Vec3{0, 0, 1});
  }
  return mesh;
}

// ---- round trips ---------------------------------------------------------------------------

TEST(IoWrite, PlyAndObjRoundTripExactlyForEveryCategory) {
  std::string dir = scratch_dir();
  for (const auto& [category, mesh] : mesh_categories()) {
    for (const char* ext : {".ply", ".obj"}) {
      SCOPED_TRACE(category + ext);
      std::string path = dir + "/" + category + ext;
      ASSERT_TRUE(write_mesh(path, mesh).ok());
      Mesh back = read_one(path, /*weld=*/false);
      expect_same_mesh(back, mesh, /*same_numbering=*/ext == std::string(".ply"));
      EXPECT_TRUE(back.normals.empty());
      EXPECT_EQ(back.stored_vertices, mesh.vertex_count());
    }
  }
}

TEST(IoWrite, StlRoundTripsTheSameTrianglesForEveryCategory) {
  std::string dir = scratch_dir();
  for (const auto& [category, mesh] : mesh_categories()) {
    SCOPED_TRACE(category);
    std::string path = dir + "/" + category + ".stl";
    ASSERT_TRUE(write_mesh(path, mesh).ok());
    EXPECT_EQ(fs::file_size(path), 84 + 50 * mesh.triangle_count());
    Mesh soup = read_one(path, /*weld=*/false);
    EXPECT_EQ(soup.triangle_count(), mesh.triangle_count());
    EXPECT_EQ(canonical_triangles(soup), canonical_triangles(mesh));
    Mesh welded = read_one(path, /*weld=*/true);
    EXPECT_EQ(welded.triangle_count(), mesh.triangle_count());
    EXPECT_EQ(welded.vertex_count(), distinct_referenced_positions(mesh));
    EXPECT_EQ(welded.stored_vertices, 3 * mesh.triangle_count());
  }
}

TEST(IoWrite, NormalsRoundTripThroughPlyAndObj) {
  std::string dir = scratch_dir();
  Mesh mesh = with_normals(make_icosphere(2, 1.5f));
  for (const char* ext : {".ply", ".obj"}) {
    SCOPED_TRACE(ext);
    std::string path = dir + "/sphere" + ext;
    ASSERT_TRUE(write_mesh(path, mesh).ok());
    Mesh back = read_one(path, /*weld=*/false);
    expect_same_mesh(back, mesh, /*same_numbering=*/ext == std::string(".ply"));
    EXPECT_EQ(back.normals.size(), mesh.normals.size());
  }
}

TEST(IoWrite, FloatsSurviveEveryFormatBitForBit) {
  std::string dir = scratch_dir();
  Mesh mesh = tricky_float_mesh();
  for (const char* ext : {".ply", ".obj"}) {
    SCOPED_TRACE(ext);
    std::string path = dir + "/floats" + ext;
    ASSERT_TRUE(write_mesh(path, mesh).ok());
    Mesh back = read_one(path, /*weld=*/false);
    ASSERT_EQ(back.positions.size(), mesh.positions.size());
    for (size_t i = 0; i < mesh.positions.size(); ++i) {
      const Vec3& a = mesh.positions[i];
      const Vec3& b = back.positions[i];
      EXPECT_EQ(std::bit_cast<uint32_t>(a.x), std::bit_cast<uint32_t>(b.x)) << a.x;
      EXPECT_EQ(std::bit_cast<uint32_t>(a.y), std::bit_cast<uint32_t>(b.y)) << a.y;
      EXPECT_EQ(std::bit_cast<uint32_t>(a.z), std::bit_cast<uint32_t>(b.z)) << a.z;
    }
  }
  std::string stl = dir + "/floats.stl";
  ASSERT_TRUE(write_mesh(stl, mesh).ok());
  EXPECT_EQ(canonical_triangles(read_one(stl, /*weld=*/false)), canonical_triangles(mesh));
}

TEST(IoWrite, ReadMemoryReadsWhatWasWritten) {
  std::string dir = scratch_dir();
  Mesh mesh = make_torus(2.0f, 0.5f, 24, 12);
  for (const char* ext : {".stl", ".ply", ".obj"}) {
    SCOPED_TRACE(ext);
    std::string path = dir + "/torus" + ext;
    ASSERT_TRUE(write_mesh(path, mesh).ok());
    std::vector<uint8_t> bytes = read_bytes(path);
    auto scene = read_memory(bytes.data(), bytes.size(), path);  // welds by default
    ASSERT_TRUE(scene.ok()) << scene.status().message();
    ASSERT_EQ(scene->parts.size(), 1u);
    EXPECT_EQ(scene->parts[0].vertex_count(), mesh.vertex_count());
    EXPECT_EQ(canonical_triangles(scene->parts[0]), canonical_triangles(mesh));
  }
}

TEST(IoWrite, RealMeshesRoundTripExactly) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  std::string input =
      data +
      "/ingvilddevold__muscle-growth/data/VHF_surfaces/Right/VHF_Right_Bone_Tibia_smooth.stl";
  if (!fs::exists(input)) GTEST_SKIP() << input << " is absent";
  Mesh mesh = read_one(input, /*weld=*/true);
  ASSERT_EQ(mesh.triangle_count(), 60362u);  // STATS.csv
  ASSERT_EQ(mesh.vertex_count(), 30183u);
  std::string dir = scratch_dir();
  for (const char* ext : {".ply", ".obj"}) {
    SCOPED_TRACE(ext);
    std::string path = dir + "/tibia" + ext;
    ASSERT_TRUE(write_mesh(path, mesh).ok());
    Mesh back = read_one(path, /*weld=*/false);
    // A welded STL numbers its vertices in first-use order, so OBJ keeps the numbering too.
    expect_same_mesh(back, mesh, /*same_numbering=*/true);
  }
  std::string stl = dir + "/tibia.stl";
  ASSERT_TRUE(write_mesh(stl, mesh).ok());
  Mesh back = read_one(stl, /*weld=*/true);
  EXPECT_EQ(back.positions, mesh.positions);  // the same first-seen order
  EXPECT_EQ(back.indices, mesh.indices);
}

// ---- the bytes of each format --------------------------------------------------------------

TEST(IoWrite, StlHasAnOsteonHeaderAndUnitFacetNormals) {
  std::string path = scratch_dir() + "/box.stl";
  Mesh mesh = make_box({0, 0, 0}, {1, 2, 3});
  mesh.name = "left\nfemur";
  ASSERT_TRUE(write_mesh(path, mesh).ok());
  std::vector<uint8_t> bytes = read_bytes(path);
  ASSERT_EQ(bytes.size(), 84u + 50u * 12u);
  std::string header(bytes.begin(), bytes.begin() + 80);
  EXPECT_EQ(header.rfind("osteon binary STL: left femur", 0), 0u) << header;
  EXPECT_EQ(header.find("solid"), std::string::npos);
  EXPECT_EQ(load_u32(bytes, 80), 12u);
  for (size_t t = 0; t < 12; ++t) {
    size_t record = 84 + 50 * t;
    Vec3 n{load_f32(bytes, record), load_f32(bytes, record + 4), load_f32(bytes, record + 8)};
    // An axis-aligned box: each facet normal is a unit axis vector pointing out of the box.
    EXPECT_FLOAT_EQ(std::abs(n.x) + std::abs(n.y) + std::abs(n.z), 1.0f) << t;
    Vec3 a{load_f32(bytes, record + 12), load_f32(bytes, record + 16),
           load_f32(bytes, record + 20)};
    Vec3 centre{0.5f, 1.0f, 1.5f};
    float outward = (a.x - centre.x) * n.x + (a.y - centre.y) * n.y + (a.z - centre.z) * n.z;
    EXPECT_GT(outward, 0.0f) << t;
    EXPECT_EQ(bytes[record + 48], 0);
    EXPECT_EQ(bytes[record + 49], 0);
  }
}

TEST(IoWrite, StlDegenerateFacetGetsAZeroNormal) {
  std::string path = scratch_dir() + "/flat.stl";
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  mesh.indices = {0, 1, 2};
  ASSERT_TRUE(write_mesh(path, mesh).ok());
  std::vector<uint8_t> bytes = read_bytes(path);
  ASSERT_EQ(bytes.size(), 134u);
  for (size_t k = 0; k < 3; ++k) EXPECT_EQ(load_f32(bytes, 84 + 4 * k), 0.0f);
}

TEST(IoWrite, PlyIsBinaryLittleEndianWithTheExpectedHeader) {
  std::string path = scratch_dir() + "/tri.ply";
  Mesh mesh;
  mesh.name = "tri";
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  mesh.indices = {0, 1, 2};
  ASSERT_TRUE(write_mesh(path, mesh).ok());
  std::string text = text_of(path);
  std::string header =
      "ply\nformat binary_little_endian 1.0\ncomment written by osteon\ncomment name tri\n"
      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  ASSERT_EQ(text.substr(0, header.size()), header);
  std::vector<uint8_t> bytes = read_bytes(path);
  ASSERT_EQ(bytes.size(), header.size() + 3 * 12 + 13);
  size_t body = header.size();
  EXPECT_EQ(load_f32(bytes, body + 12), 1.0f);  // vertex 1, x
  EXPECT_EQ(load_f32(bytes, body + 28), 1.0f);  // vertex 2, y
  size_t face = body + 36;
  EXPECT_EQ(bytes[face], 3);
  EXPECT_EQ(load_u32(bytes, face + 1), 0u);
  EXPECT_EQ(load_u32(bytes, face + 5), 1u);
  EXPECT_EQ(load_u32(bytes, face + 9), 2u);
}

TEST(IoWrite, PlyDeclaresNormalsOnlyWhenTheMeshHasThem) {
  std::string path = scratch_dir() + "/n.ply";
  Mesh mesh = with_normals(make_box({0, 0, 0}, {1, 1, 1}));
  ASSERT_TRUE(write_mesh(path, mesh).ok());
  std::string text = text_of(path);
  EXPECT_NE(
      text.find("property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"),
      std::string::npos);
  EXPECT_EQ(text.find("comment name"), std::string::npos);
  size_t body = text.find("end_header\n") + 11;
  EXPECT_EQ(text.size(), body + 8 * 24 + 12 * 13);
}

TEST(IoWrite, ObjIsShortestRoundTripText) {
  std::string path = scratch_dir() + "/tri.obj";
  Mesh mesh;
  mesh.name = "a\rb";
  mesh.positions = {{0.1f, -0.0f, 1e-7f}, {1, 2.5f, 16777216.0f}, {-3, 0, 1.0f / 3.0f}};
  mesh.indices = {0, 1, 2};
  ASSERT_TRUE(write_mesh(path, mesh).ok());
  EXPECT_EQ(text_of(path),
            "# written by osteon\no a b\n"
            "v 0.1 -0 1e-07\nv 1 2.5 16777216\nv -3 0 0.33333334\n"
            "f 1 2 3\n");
  mesh.name.clear();
  mesh.normals = {{0, 0, 1}, {0, 1, 0}, {1, 0, 0}};
  ASSERT_TRUE(write_mesh(path, mesh).ok());
  EXPECT_EQ(text_of(path),
            "# written by osteon\no mesh\n"
            "v 0.1 -0 1e-07\nv 1 2.5 16777216\nv -3 0 0.33333334\n"
            "vn 0 0 1\nvn 0 1 0\nvn 1 0 0\n"
            "f 1//1 2//2 3//3\n");
}

TEST(IoWrite, EmptyMeshWritesValidEmptyFiles) {
  std::string dir = scratch_dir();
  Mesh mesh;
  ASSERT_TRUE(write_mesh(dir + "/e.stl", mesh).ok());
  EXPECT_EQ(fs::file_size(dir + "/e.stl"), 84u);
  ASSERT_TRUE(write_mesh(dir + "/e.ply", mesh).ok());
  EXPECT_NE(text_of(dir + "/e.ply").find("element vertex 0\n"), std::string::npos);
  ASSERT_TRUE(write_mesh(dir + "/e.obj", mesh).ok());
  EXPECT_EQ(text_of(dir + "/e.obj"), "# written by osteon\no mesh\n");
}

TEST(IoWrite, ExtensionIsCaseInsensitive) {
  std::string path = scratch_dir() + "/BOX.STL";
  ASSERT_TRUE(write_mesh(path, make_box({0, 0, 0}, {1, 1, 1})).ok());
  EXPECT_EQ(fs::file_size(path), 84u + 50u * 12u);
}

// ---- refusals and failures -----------------------------------------------------------------

TEST(IoWrite, RefusesOtherExtensions) {
  std::string dir = scratch_dir();
  for (const char* name : {"/m.off", "/m.vtk", "/m.glb", "/m", "/m.stl.bak"}) {
    Status status = write_mesh(dir + name, make_box({0, 0, 0}, {1, 1, 1}));
    EXPECT_EQ(status.code(), ErrorCode::kInvalidArgument) << name;
    EXPECT_NE(status.message().find(dir + name + ": "), std::string::npos) << status.message();
  }
  EXPECT_TRUE(names_in(dir).empty());
}

TEST(IoWrite, RefusesMalformedMeshesWithoutTouchingTheTarget) {
  std::string dir = scratch_dir();
  std::string path = dir + "/m.ply";
  test::write_bytes(path, "old");
  struct Case {
    const char* expected;
    Mesh mesh;
  };
  std::vector<Case> cases;
  Mesh box = make_box({0, 0, 0}, {1, 1, 1});
  cases.push_back({"triangle 1 refers to vertex 99 of 8", box});
  cases.back().mesh.indices[4] = 99;
  cases.push_back({"37 indices is not a whole number of triangles", box});
  cases.back().mesh.indices.push_back(0);
  cases.push_back({"3 normals for 8 vertices", box});
  cases.back().mesh.normals.resize(3);
  cases.push_back({"vertex 2 has a NaN or infinite coordinate", box});
  cases.back().mesh.positions[2].y = std::numeric_limits<float>::quiet_NaN();
  cases.push_back({"normal 7 has a NaN or infinite coordinate", with_normals(box)});
  cases.back().mesh.normals[7].z = std::numeric_limits<float>::infinity();
  for (const Case& c : cases) {
    for (const char* ext : {".ply", ".obj", ".stl"}) {
      std::string target = dir + "/m" + ext;
      Status status = write_mesh(target, c.mesh);
      EXPECT_EQ(status.code(), ErrorCode::kInvalidArgument);
      EXPECT_EQ(status.message(), target + ": " + c.expected);
    }
  }
  EXPECT_EQ(text_of(path), "old");
  EXPECT_EQ(names_in(dir), std::vector<std::string>{"m.ply"});
}

TEST(IoWrite, MissingFolderIsAnIoErrorAndLeavesNothing) {
  std::string dir = scratch_dir();
  std::string path = dir + "/no/such/folder/m.stl";
  Status status = write_mesh(path, make_box({0, 0, 0}, {1, 1, 1}));
  EXPECT_EQ(status.code(), ErrorCode::kIoError);
  EXPECT_EQ(status.message(),
            path + ": cannot create a temporary file beside it: No such file or directory");
  Status raw = write_file_atomic(path, "x", 1);
  EXPECT_EQ(raw.code(), ErrorCode::kIoError);
  EXPECT_TRUE(names_in(dir).empty());
}

TEST(IoWrite, DirectoryTargetIsAnIoErrorAndLeavesNoTemporary) {
  std::string dir = scratch_dir();
  std::string target = dir + "/out.obj";
  fs::create_directory(target);
  test::write_bytes(target + "/inside.txt", "keep");
  Status status = write_mesh(target, make_box({0, 0, 0}, {1, 1, 1}));
  EXPECT_EQ(status.code(), ErrorCode::kIoError);
  EXPECT_EQ(status.message().rfind(target + ": cannot replace it: ", 0), 0u) << status.message();
  EXPECT_TRUE(fs::is_directory(target));
  EXPECT_EQ(names_in(dir), std::vector<std::string>{"out.obj"});
  EXPECT_EQ(names_in(target), std::vector<std::string>{"inside.txt"});
  EXPECT_EQ(write_file_atomic(dir, "x", 1).code(), ErrorCode::kIoError);  // the scratch folder
}

/// Lowers the file size limit for the lifetime of the object, so writes past it fail with EFBIG
/// (SIGXFSZ ignored): a disk that fills up halfway through a file.
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    getrlimit(RLIMIT_FSIZE, &saved_);
    old_handler_ = std::signal(SIGXFSZ, SIG_IGN);
    rlimit limit = saved_;
    limit.rlim_cur = bytes;
    setrlimit(RLIMIT_FSIZE, &limit);
  }
  ~FileSizeLimit() {
    setrlimit(RLIMIT_FSIZE, &saved_);
    std::signal(SIGXFSZ, old_handler_);
  }

 private:
  rlimit saved_{};
  void (*old_handler_)(int) = nullptr;
};

TEST(IoWrite, FailedWriteKeepsTheOldTargetAndRemovesTheTemporary) {
  std::string dir = scratch_dir();
  Mesh big = make_icosphere(6, 1.0f);  // 81,920 triangles: 4 MB of STL, past one buffer
  for (const char* ext : {".stl", ".ply", ".obj"}) {
    SCOPED_TRACE(ext);
    std::string path = dir + "/bone" + ext;
    test::write_bytes(path, "the old file");
    Status status;
    {
      FileSizeLimit limit(100000);
      status = write_mesh(path, big);
    }
    EXPECT_EQ(status.code(), ErrorCode::kIoError);
    EXPECT_EQ(status.message(), path + ": cannot write: File too large");
    EXPECT_EQ(text_of(path), "the old file");
    EXPECT_EQ(names_in(dir), std::vector<std::string>{std::string("bone") + ext});
    // And with room to write, the same call replaces it.
    ASSERT_TRUE(write_mesh(path, big).ok());
    EXPECT_NE(text_of(path), "the old file");
    EXPECT_EQ(read_one(path, true).triangle_count(), big.triangle_count());
    fs::remove(path);
  }
}

TEST(IoWrite, AtomicWriteStoresExactBytes) {
  std::string dir = scratch_dir();
  std::vector<uint8_t> bytes(3 * (size_t{1} << 20) + 17);  // more than the 1 MiB buffer
  std::mt19937 rng(3);
  for (uint8_t& b : bytes) b = static_cast<uint8_t>(rng());
  ASSERT_TRUE(write_file_atomic(dir + "/blob", bytes.data(), bytes.size()).ok());
  EXPECT_EQ(read_bytes(dir + "/blob"), bytes);
  ASSERT_TRUE(write_file_atomic(dir + "/blob", nullptr, 0).ok());
  EXPECT_EQ(fs::file_size(dir + "/blob"), 0u);
  EXPECT_EQ(names_in(dir), std::vector<std::string>{"blob"});
}

TEST(IoWrite, ConcurrentWritersLeaveOneWholeFile) {
  std::string dir = scratch_dir();
  std::string path = dir + "/shared.bin";
  constexpr int kThreads = 4;
  std::vector<std::vector<uint8_t>> contents;
  for (int i = 0; i < kThreads; ++i)
    contents.emplace_back(size_t{1} << 20 | size_t(i), static_cast<uint8_t>('a' + i));
  std::vector<std::thread> threads;
  std::vector<int> ok(kThreads, 0);
  for (int i = 0; i < kThreads; ++i) {
    threads.emplace_back([&, i] {
      for (int round = 0; round < 5; ++round)
        ok[i] += write_file_atomic(path, contents[i].data(), contents[i].size()).ok();
    });
  }
  for (auto& t : threads) t.join();
  for (int i = 0; i < kThreads; ++i) EXPECT_EQ(ok[i], 5);
  std::vector<uint8_t> final_bytes = read_bytes(path);
  EXPECT_NE(std::find(contents.begin(), contents.end(), final_bytes), contents.end());
  EXPECT_EQ(names_in(dir), std::vector<std::string>{"shared.bin"});
}

}  // namespace io_write_test
}  // namespace
}  // namespace osteon
