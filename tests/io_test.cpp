// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>

#include "fixtures.hpp"
#include "io_internal.hpp"
#include "osteon/io.hpp"
#include "support/phantom.hpp"

namespace osteon {
namespace {
namespace io_test {

namespace fs = std::filesystem;

const char* kAsciiTriangle =
    "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 10 0 0\nvertex 0 10 0\n"
    "endloop\nendfacet\nendsolid t\n";

TEST(Io, FormatFromExtensionIgnoresCase) {
  EXPECT_EQ(format_from_extension("a/b/Femur.STL"), Format::kStl);
  EXPECT_EQ(format_from_extension("x.Ply"), Format::kPly);
  EXPECT_EQ(format_from_extension("x.glb"), Format::kGlb);
  EXPECT_EQ(format_from_extension("x.gltf"), Format::kGltf);
  EXPECT_EQ(format_from_extension("x.vtk"), Format::kVtk);
  EXPECT_EQ(format_from_extension("x.off"), Format::kOff);
  EXPECT_EQ(format_from_extension("x.obj"), Format::kObj);
  EXPECT_EQ(format_from_extension("x.txt"), Format::kUnknown);
  EXPECT_STREQ(format_name(Format::kGlb), "glb");
}

TEST(Io, SniffsTheFormatFromTheBytes) {
  auto sniff = [](const std::string& s) {
    return detail::sniff_format(reinterpret_cast<const uint8_t*>(s.data()), s.size());
  };
  EXPECT_EQ(sniff("ply\nformat ascii 1.0\n"), Format::kPly);
  EXPECT_EQ(sniff("OFF\n3 1 0\n"), Format::kOff);
  EXPECT_EQ(sniff("# vtk DataFile Version 3.0\n"), Format::kVtk);
  EXPECT_EQ(sniff(std::string("glTF\x02\0\0\0", 8)), Format::kGlb);
  EXPECT_EQ(sniff("  {\"asset\":{}}"), Format::kGltf);
  EXPECT_EQ(sniff("solid x\n"), Format::kStl);
  EXPECT_EQ(sniff("# comment\nv 0 0 0\n"), Format::kObj);
  EXPECT_EQ(sniff("hello"), Format::kUnknown);
  // A file without a known extension is read by what its bytes say.
  Scene scene = test::parse_or_fail(kAsciiTriangle, "mystery.dat");
  EXPECT_EQ(scene.parts.at(0).triangle_count(), 1u);
  EXPECT_NE(test::parse_error("hello world", "mystery.dat").find("unknown mesh format"),
            std::string::npos);
}

TEST(Io, MissingPathsAndFoldersWithoutMeshesAreClearErrors) {
  Result<Scene> missing = read_path("/nonexistent/osteon/femur.stl");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().code(), ErrorCode::kIoError);
  EXPECT_EQ(missing.status().message(), "/nonexistent/osteon/femur.stl: no such file or folder");

  std::string dir = test::scratch_dir();
  test::write_bytes(dir + "/notes.txt", "not a mesh");
  Result<Scene> empty = read_path(dir);
  ASSERT_FALSE(empty.ok());
  EXPECT_NE(empty.status().message().find("holds no mesh file"), std::string::npos);

  test::write_bytes(dir + "/empty.stl", "");
  Result<Scene> zero = read_path(dir + "/empty.stl");
  ASSERT_FALSE(zero.ok());
  EXPECT_NE(zero.status().message().find("empty.stl: file is empty (byte 0)"), std::string::npos);
}

TEST(Io, UnreadableFileIsAnIoError) {
  if (geteuid() == 0) GTEST_SKIP() << "root reads every file; permission test skipped";
  std::string dir = test::scratch_dir();
  test::write_bytes(dir + "/locked.stl", kAsciiTriangle);
  chmod((dir + "/locked.stl").c_str(), 0);
  Result<Scene> r = read_path(dir + "/locked.stl");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("cannot open"), std::string::npos);
}

// The whole-file read that package, names and .seg readers share.
TEST(Io, ReadFileChecksBeforeItAllocates) {
  const std::string dir = test::scratch_dir();
  test::write_bytes(dir + "/bytes.bin", std::string("abc\0def", 7));
  Result<std::vector<uint8_t>> bytes = read_file(dir + "/bytes.bin");
  ASSERT_TRUE(bytes.ok()) << bytes.status().message();
  EXPECT_EQ(bytes->size(), 7u);
  EXPECT_EQ((*bytes)[4], 'd');
  test::write_bytes(dir + "/empty.bin", "");
  ASSERT_TRUE(read_file(dir + "/empty.bin").ok());
  EXPECT_TRUE(read_file(dir + "/empty.bin")->empty());

  Result<std::vector<uint8_t>> missing = read_file(dir + "/absent.bin");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().code(), ErrorCode::kIoError);
  EXPECT_NE(missing.status().message().find("absent.bin: cannot open"), std::string::npos);
  Result<std::vector<uint8_t>> folder = read_file(dir);
  ASSERT_FALSE(folder.ok());
  EXPECT_NE(folder.status().message().find("is a folder"), std::string::npos);
  Result<std::vector<uint8_t>> big = read_file(dir + "/bytes.bin", 6);
  ASSERT_FALSE(big.ok());
  EXPECT_EQ(big.status().code(), ErrorCode::kInvalidArgument);
  EXPECT_NE(big.status().message().find("over the limit of 6"), std::string::npos);
}

TEST(Io, FolderGivesOnePartPerFileNamedByRelativePath) {
  std::string dir = test::scratch_dir();
  fs::create_directories(dir + "/Left");
  fs::create_directories(dir + "/Right");
  test::write_bytes(dir + "/Right/femur.stl", kAsciiTriangle);
  test::write_bytes(dir + "/Left/femur.stl", kAsciiTriangle);
  test::write_bytes(dir + "/skull.stl", kAsciiTriangle);
  test::write_bytes(dir + "/.hidden.stl", "garbage");
  test::write_bytes(dir + "/readme.md", "# not a mesh");
  Result<Scene> scene = read_path(dir);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  ASSERT_EQ(scene->parts.size(), 3u);
  EXPECT_EQ(scene->parts[0].name, "Left/femur");
  EXPECT_EQ(scene->parts[1].name, "Right/femur");
  EXPECT_EQ(scene->parts[2].name, "skull");
  EXPECT_EQ(scene->parts[2].source, dir + "/skull.stl");
  for (const Mesh& part : scene->parts) {
    EXPECT_EQ(part.unit, Unit::kMillimetre);  // 10 units across: guessed millimetres
    EXPECT_EQ(part.unit_source, UnitSource::kGuessed);
  }
}

TEST(Io, ABadFileInAFolderFailsTheFolderAndNamesTheFile) {
  std::string dir = test::scratch_dir();
  test::write_bytes(dir + "/a.stl", kAsciiTriangle);
  test::write_bytes(dir + "/b.stl", "solid broken\nfacet normal 0 0 1\nouter loop\n");
  Result<Scene> scene = read_path(dir);
  ASSERT_FALSE(scene.ok());
  EXPECT_EQ(scene.status().message().rfind(dir + "/b.stl: ", 0), 0u) << scene.status().message();
}

TEST(Io, UnitOptionOverridesTheGuess) {
  ReadOptions options;
  options.unit = Unit::kMetre;
  Scene scene = test::parse_or_fail(kAsciiTriangle, "t.stl", options);
  EXPECT_EQ(scene.parts.at(0).unit, Unit::kMetre);
  EXPECT_EQ(scene.parts.at(0).unit_source, UnitSource::kUser);
}

TEST(Io, FileSizeLimitIsEnforced) {
  std::string dir = test::scratch_dir();
  test::write_bytes(dir + "/t.stl", kAsciiTriangle);
  ReadOptions options;
  options.max_file_bytes = 10;
  Result<Scene> r = read_path(dir + "/t.stl", options);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("over the limit of 10"), std::string::npos);
  Result<Scene> folder = read_path(dir, options);
  ASSERT_FALSE(folder.ok());
  EXPECT_NE(folder.status().message().find("more than the limit"), std::string::npos);
}

TEST(Io, AFolderPassedWhereAFileIsExpectedIsRead) {
  // read_path takes both; a folder named like a mesh file is still a folder.
  std::string dir = test::scratch_dir() + "/bones.stl";
  fs::create_directories(dir);
  test::write_bytes(dir + "/rib.stl", kAsciiTriangle);
  Result<Scene> scene = read_path(dir);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  EXPECT_EQ(scene->parts.at(0).name, "rib");
}

}  // namespace io_test
}  // namespace
}  // namespace osteon
