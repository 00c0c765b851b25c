// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "fixtures.hpp"
#include "osteon/io.hpp"
#include "osteon/mesh.hpp"

namespace osteon {
namespace {
namespace io_vtk_test {

using test::parse_error;
using test::parse_or_fail;

ReadOptions no_weld() {
  ReadOptions options;
  options.weld = false;
  return options;
}

// Big-endian encoders for BINARY files.
template <class T>
std::string be(T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  if constexpr (std::endian::native == std::endian::little) {
    for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
  }
  return std::string(bytes, sizeof(T));
}
std::string be_floats(std::initializer_list<float> values) {
  std::string out;
  for (float v : values) out += be(v);
  return out;
}
std::string be_ints(std::initializer_list<int32_t> values) {
  std::string out;
  for (int32_t v : values) out += be(v);
  return out;
}

const char* kAsciiHeader = "# vtk DataFile Version 3.0\ntest\nASCII\nDATASET POLYDATA\n";
const char* kBinaryHeader = "# vtk DataFile Version 4.0\nvtk output\nBINARY\nDATASET POLYDATA\n";

// A unit square (0,1,2,3) and a triangle (1,4,2) in ASCII.
const char* kSquareAndTriangle =
    "POINTS 5 float\n"
    "0 0 0  1 0 0  1 1 0\n"
    "0 1 0  2 0.5 0\n"
    "POLYGONS 2 9\n"
    "4 0 1 2 3\n"
    "3 1 4 2\n";

std::vector<uint32_t> indices_of(const Scene& scene) {
  return scene.parts.empty() ? std::vector<uint32_t>{} : scene.parts[0].indices;
}

Status read_status(const std::string& bytes, const std::string& source = "m.vtk") {
  auto result = read_memory(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), source);
  return result.status();
}

TEST(IoVtk, AsciiPolygonsAreFanTriangulated) {
  Scene scene = parse_or_fail(std::string(kAsciiHeader) + kSquareAndTriangle, "m.vtk", no_weld());
  ASSERT_EQ(scene.parts.size(), 1u);
  const Mesh& mesh = scene.parts[0];
  EXPECT_EQ(mesh.name, "m");
  EXPECT_EQ(mesh.stored_vertices, 5u);
  ASSERT_EQ(mesh.positions.size(), 5u);
  EXPECT_EQ(mesh.positions[4], (Vec3{2, 0.5f, 0}));
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 1, 4, 2}));
  EXPECT_TRUE(mesh.normals.empty());
}

TEST(IoVtk, KeywordsAreCaseInsensitiveAndCrLfIsAccepted) {
  std::string text =
      "# vtk DataFile Version 2.0\r\ntitle\r\nascii\r\ndataset polydata\r\n"
      "points 3 double\r\n0 0 0 1 0 0 0 1 0\r\npolygons 1 4\r\n3 0 1 2\r\n";
  Scene scene = parse_or_fail(text, "m.vtk", no_weld());
  EXPECT_EQ(indices_of(scene), (std::vector<uint32_t>{0, 1, 2}));
}

TEST(IoVtk, TriangleStripsAlternateOrientation) {
  // Strip 0 1 2 3 4: (0,1,2), (2,1,3), (2,3,4): all counter-clockwise in the xy plane.
  std::string text = std::string(kAsciiHeader) +
                     "POINTS 5 float\n0 0 0 0 1 0 1 0 0 1 1 0 2 0 0\n"
                     "TRIANGLE_STRIPS 1 6\n5 0 1 2 3 4\n";
  Scene scene = parse_or_fail(text, "m.vtk", no_weld());
  EXPECT_EQ(indices_of(scene), (std::vector<uint32_t>{0, 1, 2, 2, 1, 3, 2, 3, 4}));
}

TEST(IoVtk, StripTrianglesWithARepeatedIndexAreDropped) {
  // Strip 0 1 2 2 3 4: j=1 (2,1,2) and j=2 (2,2,3) repeat an index; j=3 gives (3,2,4).
  std::string text = std::string(kAsciiHeader) +
                     "POINTS 5 float\n0 0 0 0 1 0 1 0 0 1 1 0 2 0 0\n"
                     "TRIANGLE_STRIPS 2 10\n6 0 1 2 2 3 4\n2 0 1\n";
  Scene scene = parse_or_fail(text, "m.vtk", no_weld());
  EXPECT_EQ(indices_of(scene), (std::vector<uint32_t>{0, 1, 2, 3, 2, 4}));
}

TEST(IoVtk, PolygonsWithFewerThanThreeCornersGiveNoTriangle) {
  std::string text = std::string(kAsciiHeader) +
                     "POINTS 3 float\n0 0 0 1 0 0 0 1 0\n"
                     "POLYGONS 3 8\n0\n2 0 1\n3 0 1 2\n";
  Scene scene = parse_or_fail(text, "m.vtk", no_weld());
  EXPECT_EQ(indices_of(scene), (std::vector<uint32_t>{0, 1, 2}));
}

TEST(IoVtk, VerticesAndLinesAreSkipped) {
  std::string text = std::string(kAsciiHeader) +
                     "POINTS 4 float\n0 0 0 1 0 0 0 1 0 1 1 0\n"
                     "VERTICES 2 4\n1 0\n1 3\n"
                     "LINES 1 4\n3 0 1 3\n"
                     "POLYGONS 1 4\n3 0 1 2\n";
  Scene scene = parse_or_fail(text, "m.vtk", no_weld());
  EXPECT_EQ(indices_of(scene), (std::vector<uint32_t>{0, 1, 2}));
}

TEST(IoVtk, AsciiPointDataNormalsAfterOtherAttributes) {
  std::string text = std::string(kAsciiHeader) +
                     "FIELD FieldData 1\nTIME 1 1 double\n2.5\n"
                     "POINTS 3 float\n0 0 0 1 0 0 0 1 0\n"
                     "METADATA\nINFORMATION 0\n\n"
                     "POLYGONS 1 4\n3 0 1 2\n"
                     "CELL_DATA 1\nSCALARS cellid int 1\nLOOKUP_TABLE default\n7\n"
                     "NORMALS cellnormal float\n0 0 1\n"
                     "POINT_DATA 3\n"
                     "SCALARS temperature float 2\nLOOKUP_TABLE my_table\n1 2 3 4 5 6\n"
                     "LOOKUP_TABLE my_table 2\n0 0 0 1 1 1 1 1\n"
                     "COLOR_SCALARS rgb 3\n1 0 0 0 1 0 0 0 1\n"
                     "TEXTURE_COORDINATES uv 2 float\n0 0 1 0 0 1\n"
                     "VECTORS velocity double\n1 1 1 2 2 2 3 3 3\n"
                     "FIELD FieldData 2\nids 1 3 int\n1 2 3\nNULL_ARRAY\n"
                     "NORMALS Normals float\n0 0 1 0 0.6 0.8 1 0 0\n"
                     "TENSORS t float\n" +
                     std::string(27 * 2, ' ') +
                     "\n";  // truncated tensors after the normals: ignored
  Scene scene = parse_or_fail(text, "m.vtk", no_weld());
  ASSERT_EQ(scene.parts.size(), 1u);
  const Mesh& mesh = scene.parts[0];
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2}));
  ASSERT_EQ(mesh.normals.size(), 3u);
  EXPECT_EQ(mesh.normals[0], (Vec3{0, 0, 1}));
  EXPECT_EQ(mesh.normals[1], (Vec3{0, 0.6f, 0.8f}));
  EXPECT_EQ(mesh.normals[2], (Vec3{1, 0, 0}));
}

TEST(IoVtk, NormalsWhoseCountDiffersFromThePointsAreIgnored) {
  std::string text = std::string(kAsciiHeader) +
                     "POINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 1 4\n3 0 1 2\n"
                     "POINT_DATA 2\nNORMALS n float\n0 0 1 0 0 1\n";
  Scene scene = parse_or_fail(text, "m.vtk", no_weld());
  ASSERT_EQ(scene.parts.size(), 1u);
  EXPECT_TRUE(scene.parts[0].normals.empty());
}

TEST(IoVtk, NonFiniteNormalsAreDropped) {
  std::string text = std::string(kAsciiHeader) +
                     "POINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 1 4\n3 0 1 2\n"
                     "POINT_DATA 3\nNORMALS n float\n0 0 1 nan 0 1 0 0 1\n";
  Scene scene = parse_or_fail(text, "m.vtk", no_weld());
  ASSERT_EQ(scene.parts.size(), 1u);
  EXPECT_EQ(scene.parts[0].triangle_count(), 1u);
  EXPECT_TRUE(scene.parts[0].normals.empty());
}

TEST(IoVtk, UnreadablePointDataKeepsTheGeometry) {
  for (const char* tail : {"POINT_DATA 3\nSCALARS names string\nLOOKUP_TABLE default\na b c\n",
                           "POINT_DATA 3\nWHATEVER 1 2 3\n", "POINT_DATA x\n",
                           "POINT_DATA 3\nNORMALS n float\n0 0 1 0 0\n",
                           "POINT_DATA 3\nNORMALS n float\n0 0 1 0 0 1 0 zero 1\n",
                           "POINT_DATA 3\nSCALARS s float 9\nLOOKUP_TABLE default\n"}) {
    SCOPED_TRACE(tail);
    std::string text = std::string(kAsciiHeader) +
                       "POINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 1 4\n3 0 1 2\n" + tail;
    Scene scene = parse_or_fail(text, "m.vtk", no_weld());
    ASSERT_EQ(scene.parts.size(), 1u);
    EXPECT_EQ(scene.parts[0].indices, (std::vector<uint32_t>{0, 1, 2}));
    EXPECT_TRUE(scene.parts[0].normals.empty());
  }
}

// A binary file as VTK writes it: big-endian data right after each declaring line, a newline
// after each block.
std::string binary_tetrahedron(bool with_normals) {
  std::string s = kBinaryHeader;
  s += "POINTS 4 float\n";
  s += be_floats({0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1});
  s += "\nPOLYGONS 2 8\n";
  s += be_ints({3, 0, 2, 1, 3, 0, 1, 3});
  s += "\nTRIANGLE_STRIPS 1 5\n";
  s += be_ints({4, 1, 2, 3, 0});  // (1,2,3), (3,2,0)
  s += "\n";
  if (with_normals) {
    s += "POINT_DATA 4\nSCALARS s unsigned_char\nLOOKUP_TABLE default\n";
    s += std::string("\x01\x0a\x20\x0d", 4);  // bytes that look like whitespace
    s += "\nNORMALS Normals float\n";
    s += be_floats({-1, -1, -1, 1, 0, 0, 0, 1, 0, 0, 0, 1});
    s += "\n";
  }
  return s;
}

TEST(IoVtk, BinaryBigEndianPolygonsStripsAndNormals) {
  Scene scene = parse_or_fail(binary_tetrahedron(true), "m.vtk", no_weld());
  ASSERT_EQ(scene.parts.size(), 1u);
  const Mesh& mesh = scene.parts[0];
  ASSERT_EQ(mesh.positions.size(), 4u);
  EXPECT_EQ(mesh.positions[3], (Vec3{0, 0, 1}));
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 2, 1, 0, 1, 3, 1, 2, 3, 3, 2, 0}));
  ASSERT_EQ(mesh.normals.size(), 4u);
  EXPECT_EQ(mesh.normals[0], (Vec3{-1, -1, -1}));
  EXPECT_EQ(mesh.normals[1], (Vec3{1, 0, 0}));
}

TEST(IoVtk, BinaryBlocksAfterTrailingBlanksAndWithoutTrailingNewline) {
  std::string s = kBinaryHeader;
  s += "POINTS 3 double   \r\n";  // blanks and CR before the newline: data starts after it
  for (double v : {0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0}) s += be(v);
  s += "POLYGONS 1 4\n";  // no newline after the previous block
  s += be_ints({3, 0, 1, 2});
  Scene scene = parse_or_fail(s, "m.vtk", no_weld());
  ASSERT_EQ(scene.parts.size(), 1u);
  EXPECT_EQ(scene.parts[0].positions[1], (Vec3{1, 0, 0}));
  EXPECT_EQ(scene.parts[0].indices, (std::vector<uint32_t>{0, 1, 2}));
}

TEST(IoVtk, BinaryMetadataAndFieldBlocksAreSkipped) {
  std::string s = kBinaryHeader;
  s += "FIELD FieldData 1\nTIME 1 1 double\n" + be(3.5) + "\n";
  s += "POINTS 3 float\n" + be_floats({0, 0, 0, 1, 0, 0, 0, 1, 0}) + "\n";
  s += "METADATA\nINFORMATION 1\nNAME L2_NORM_RANGE LOCATION vtkDataArray\nDATA 2 0 1\n\n";
  s += "LINES 1 3\n" + be_ints({2, 0, 1}) + "\n";
  s += "POLYGONS 1 4\n" + be_ints({3, 0, 1, 2}) + "\n";
  s += "POINT_DATA 3\nFIELD FieldData 1\nids 1 3 vtkIdType\n" + be_ints({5, 6, 7}) + "\n";
  s += "NORMALS n double\n";
  for (double v : {0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0}) s += be(v);
  Scene scene = parse_or_fail(s, "m.vtk", no_weld());
  ASSERT_EQ(scene.parts.size(), 1u);
  EXPECT_EQ(scene.parts[0].indices, (std::vector<uint32_t>{0, 1, 2}));
  ASSERT_EQ(scene.parts[0].normals.size(), 3u);
  EXPECT_EQ(scene.parts[0].normals[2], (Vec3{0, 0, 1}));
}

TEST(IoVtk, Version5OffsetsAndConnectivity) {
  std::string ascii =
      "# vtk DataFile Version 5.1\nv5\nASCII\nDATASET POLYDATA\n"
      "POINTS 5 float\n0 0 0 1 0 0 1 1 0 0 1 0 2 0.5 0\n"
      "LINES 2 2\nOFFSETS vtktypeint64\n0 2\nCONNECTIVITY vtktypeint64\n0 1\n"
      "POLYGONS 3 7\nOFFSETS vtktypeint64\n0 4 7\nCONNECTIVITY vtktypeint64\n0 1 2 3 1 4 2\n"
      "TRIANGLE_STRIPS 0 0\nOFFSETS vtktypeint64\n\nCONNECTIVITY vtktypeint64\n\n";
  Scene scene = parse_or_fail(ascii, "m.vtk", no_weld());
  EXPECT_EQ(indices_of(scene), (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 1, 4, 2}));

  std::string binary = "# vtk DataFile Version 5.1\nv5\nBINARY\nDATASET POLYDATA\n";
  binary += "POINTS 4 float\n" + be_floats({0, 0, 0, 0, 1, 0, 1, 0, 0, 1, 1, 0}) + "\n";
  binary += "TRIANGLE_STRIPS 2 4\nOFFSETS vtktypeint64\n";
  binary += be(int64_t{0}) + be(int64_t{4}) + "\n";
  binary += "CONNECTIVITY vtktypeint32\n";  // any integer type
  binary += be_ints({0, 1, 2, 3}) + "\n";
  scene = parse_or_fail(binary, "m.vtk", no_weld());
  EXPECT_EQ(indices_of(scene), (std::vector<uint32_t>{0, 1, 2, 2, 1, 3}));
}

TEST(IoVtk, Version5BadOffsetsAreErrors) {
  std::string head =
      "# vtk DataFile Version 5.1\nv5\nASCII\nDATASET POLYDATA\n"
      "POINTS 3 float\n0 0 0 1 0 0 0 1 0\n";
  EXPECT_NE(parse_error(head + "POLYGONS 2 3\nOFFSETS vtktypeint64\n1 3\n"
                               "CONNECTIVITY vtktypeint64\n0 1 2\n",
                        "m.vtk")
                .find("the first offset is 1, not 0"),
            std::string::npos);
  EXPECT_NE(parse_error(head + "POLYGONS 2 3\nOFFSETS vtktypeint64\n0 4\n"
                               "CONNECTIVITY vtktypeint64\n0 1 2\n",
                        "m.vtk")
                .find("the last offset is 4, but CONNECTIVITY has 3 values"),
            std::string::npos);
  EXPECT_NE(parse_error(head + "POLYGONS 3 3\nOFFSETS vtktypeint64\n0 3 2\n"
                               "CONNECTIVITY vtktypeint64\n0 1 2\n",
                        "m.vtk")
                .find("offset 2 decreases"),
            std::string::npos);
  EXPECT_NE(parse_error(head + "POLYGONS 2 3\nCONNECTIVITY vtktypeint64\n0 1 2\n", "m.vtk")
                .find("expected OFFSETS, found 'CONNECTIVITY'"),
            std::string::npos);
  EXPECT_NE(parse_error(head + "POLYGONS 2 3\nOFFSETS float\n0 3\n", "m.vtk")
                .find("POLYGONS OFFSETS must have an integer type"),
            std::string::npos);
}

TEST(IoVtk, OtherDatasetsAreUnsupported) {
  for (const char* dataset : {"UNSTRUCTURED_GRID", "STRUCTURED_POINTS", "RECTILINEAR_GRID"}) {
    std::string text = std::string("# vtk DataFile Version 3.0\nt\nASCII\nDATASET ") + dataset +
                       "\nPOINTS 0 float\n";
    Status status = read_status(text);
    EXPECT_EQ(status.code(), ErrorCode::kUnsupported);
    EXPECT_EQ(status.message(), std::string("m.vtk: DATASET ") + dataset +
                                    " is not supported (only POLYDATA surfaces are read) (line 4)");
  }
  Status status = read_status("# vtk DataFile Version 3.0\nt\nASCII\nFIELD f 0\n");
  EXPECT_EQ(status.code(), ErrorCode::kUnsupported);
}

TEST(IoVtk, HeaderErrors) {
  EXPECT_EQ(parse_error("# vtk DataFile Versoin 3.0\nt\nASCII\n", "m.vtk"),
            "m.vtk: not a legacy VTK file: it must begin with '# vtk DataFile Version' (line 1)");
  EXPECT_EQ(parse_error("# vtk DataFile Version 3.0\nt\nTEXT\n", "m.vtk"),
            "m.vtk: expected ASCII or BINARY, found 'TEXT' (line 3)");
  EXPECT_EQ(parse_error("# vtk DataFile Version 3.0\nt\nASCII\nPOINTS 3 float\n", "m.vtk"),
            "m.vtk: expected DATASET, found 'POINTS' (line 4)");
  EXPECT_EQ(parse_error(std::string(kAsciiHeader) + "POLYGONS 0 0\n", "m.vtk"),
            "m.vtk: the POLYDATA has no POINTS section (line 6)");
  EXPECT_EQ(
      parse_error(std::string(kAsciiHeader) + "POINTS 1 float\n0 0 0\nPOLYGONZ 1 4\n", "m.vtk"),
      "m.vtk: unknown keyword 'POLYGONZ' in POLYDATA (line 7)");
  Status status = read_status(std::string(kAsciiHeader) + "POINTS 1 string\na\n");
  EXPECT_EQ(status.code(), ErrorCode::kUnsupported);
  EXPECT_EQ(status.message(), "m.vtk: POINTS: data type 'string' is not supported (line 5)");
}

TEST(IoVtk, IndexOutOfRangeIsAnError) {
  std::string text = std::string(kAsciiHeader) +
                     "POINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 2 8\n3 0 1 2\n3 0 1 7\n";
  EXPECT_EQ(parse_error(text, "m.vtk"),
            "m.vtk: POLYGONS: cell 1 uses point 7, but there are 3 points (line 7)");
  text = std::string(kAsciiHeader) +
         "POINTS 3 float\n0 0 0 1 0 0 0 1 0\nTRIANGLE_STRIPS 1 4\n3 0 -1 2\n";
  EXPECT_EQ(parse_error(text, "m.vtk"),
            "m.vtk: TRIANGLE_STRIPS: cell 0 uses point -1, but there are 3 points (line 7)");
}

TEST(IoVtk, CellListsThatDisagreeWithTheirSizeAreErrors) {
  std::string head = std::string(kAsciiHeader) + "POINTS 3 float\n0 0 0 1 0 0 0 1 0\n";
  EXPECT_NE(parse_error(head + "POLYGONS 1 5\n3 0 1 2 0\n", "m.vtk")
                .find("size is 5, but the 1 cells use 4 values"),
            std::string::npos);
  EXPECT_NE(parse_error(head + "POLYGONS 2 4\n3 0 1 2\n", "m.vtk")
                .find("2 cells declared, but the 4 values end after 1"),
            std::string::npos);
  EXPECT_NE(parse_error(head + "POLYGONS 1 4\n9 0 1 2\n", "m.vtk").find("cell 0 claims 9 corners"),
            std::string::npos);
  EXPECT_NE(
      parse_error(head + "POLYGONS 1 4\n-3 0 1 2\n", "m.vtk").find("cell 0 claims -3 corners"),
      std::string::npos);
  EXPECT_NE(
      parse_error(head + "POLYGONS 5 4\n3 0 1 2\n", "m.vtk").find("5 cells cannot fit in 4 values"),
      std::string::npos);
  EXPECT_NE(
      parse_error(head + "POLYGONS 1 4\n3 0 1.5 2\n", "m.vtk").find("'1.5' is not an integer"),
      std::string::npos);
  EXPECT_NE(parse_error(head + "POLYGONS 1 4\n3 0 1\n", "m.vtk")
                .find("the file ends after 3 of 4 values"),
            std::string::npos);
}

TEST(IoVtk, NonFiniteCoordinatesAreErrors) {
  std::string text = std::string(kAsciiHeader) + "POINTS 3 float\n0 0 0\n1 nan 0\n0 1 0\n";
  EXPECT_EQ(parse_error(text, "m.vtk"),
            "m.vtk: vertex 1 has a NaN or infinite coordinate (line 7)");
  std::string s = kBinaryHeader;
  s += "POINTS 3 float\n" + be_floats({0, 0, 0, 1, 0, 0, 0, INFINITY, 0}) + "\n";
  EXPECT_EQ(parse_error(s, "m.vtk"), "m.vtk: vertex 2 has a NaN or infinite coordinate (byte 101)");
  s = kBinaryHeader;
  s += "POINTS 1 double\n" + be(0.0) + be(1e300) + be(0.0);  // finite, but not as a float
  EXPECT_NE(parse_error(s, "m.vtk").find("vertex 0 has a NaN or infinite coordinate"),
            std::string::npos);
}

TEST(IoVtk, HugeCountsFailFastWithoutAllocating) {
  std::string s = kBinaryHeader;
  s += "POINTS 4000000000 float\n" + be_floats({0, 0, 0});
  EXPECT_EQ(parse_error(s, "m.vtk"),
            "m.vtk: POINTS: 4000000000 points declared, room for at most 4 (byte 86)");
  s = kBinaryHeader;
  s += "POINTS 1 float\n" + be_floats({0, 0, 0}) + "\nPOLYGONS 1 2000000000\n" + be_ints({3, 0});
  EXPECT_NE(parse_error(s, "m.vtk").find("POLYGONS: 2000000000 values declared, room for 2"),
            std::string::npos);
  s = std::string(kAsciiHeader) + "POINTS 1 float\n0 0 0\nPOLYGONS 1 9223372036854775807\n3 0";
  EXPECT_NE(parse_error(s, "m.vtk").find("9223372036854775807 values declared, room for at most"),
            std::string::npos);
  s = std::string(kAsciiHeader) + "POINTS 99999999999999999999 float\n";
  EXPECT_NE(parse_error(s, "m.vtk").find("expected the number of POINTS, found"),
            std::string::npos);
  // The attribute counts are hostile too: the geometry survives, nothing huge is allocated.
  s = binary_tetrahedron(false) + "POINT_DATA 4611686018427387904\nNORMALS n float\n";
  Scene scene = parse_or_fail(s, "m.vtk");
  ASSERT_EQ(scene.parts.size(), 1u);
  EXPECT_TRUE(scene.parts[0].normals.empty());
}

TEST(IoVtk, TruncatedBinaryFilesFailCleanly) {
  const std::string full = binary_tetrahedron(true);
  // A cut right after a geometry block (or its newline) leaves a valid file with fewer sections.
  const size_t points_end = full.find("\nPOLYGONS");
  const size_t polygons_end = full.find("\nTRIANGLE_STRIPS");
  const size_t geometry_end = full.find("\nPOINT_DATA");
  std::map<size_t, size_t> triangles_at = {{points_end, 0},   {points_end + 1, 0},
                                           {polygons_end, 2}, {polygons_end + 1, 2},
                                           {geometry_end, 4}, {geometry_end + 1, 4}};
  for (size_t cut = 1; cut < full.size(); ++cut) {
    auto result = read_memory(reinterpret_cast<const uint8_t*>(full.data()), cut, "m.vtk");
    // Errors: a cut inside a geometry block, or one that leaves half a keyword ("POINT_D").
    bool half_keyword = cut > geometry_end + 1 && cut < geometry_end + 1 + 10;
    if (cut < geometry_end || half_keyword) {
      if (triangles_at.count(cut) == 0) {
        EXPECT_FALSE(result.ok()) << "cut at " << cut;
        continue;
      }
    }
    ASSERT_TRUE(result.ok()) << "cut at " << cut << ": " << result.status().message();
    size_t expected = cut < geometry_end ? triangles_at.at(cut) : 4;
    EXPECT_EQ(result->parts[0].triangle_count(), expected) << "cut at " << cut;
    EXPECT_EQ(result->parts[0].normals.empty(), cut < full.size() - 1) << "cut at " << cut;
  }
}

TEST(IoVtk, FlippedBitsNeverCrash) {
  const std::string full = binary_tetrahedron(true);
  for (size_t i = 0; i < full.size(); ++i) {
    for (int bit : {0, 3, 7}) {
      std::string bytes = full;
      bytes[i] = static_cast<char>(bytes[i] ^ (1 << bit));
      auto result =
          read_memory(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), "m.vtk");
      if (result.ok()) {
        for (const Mesh& part : result->parts) {
          for (uint32_t index : part.indices) ASSERT_LT(index, part.positions.size());
        }
      }
    }
  }
}

// ---- real data --------------------------------------------------------------------------------

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

TEST(IoVtk, RealAtlasFilesMatchStats) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  auto stats = read_stats(data + "/STATS.csv");
  const std::string folder = "stity__spl-abdominal-atlas/Data";
  size_t files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(data + "/" + folder)) {
    if (entry.path().extension() != ".vtk") continue;
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
    EXPECT_EQ(mesh.normals.size(), mesh.vertex_count());  // POINT_DATA NORMALS, kept by welding
    Aabb box = bounding_box(mesh);
    EXPECT_NEAR(box.max.x - box.min.x, std::stod(row.at("bbox_x")), 2e-3);
    EXPECT_NEAR(box.max.y - box.min.y, std::stod(row.at("bbox_y")), 2e-3);
    EXPECT_NEAR(box.max.z - box.min.z, std::stod(row.at("bbox_z")), 2e-3);
    ++files;
  }
  EXPECT_EQ(files, 27u);
}

}  // namespace io_vtk_test
}  // namespace
}  // namespace osteon
