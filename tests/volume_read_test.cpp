// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "fixtures.hpp"
#include "osteon/volume.hpp"

// The label-volume readers on small volumes written here byte by byte (NIfTI-1 and -2 headers,
// NRRD text headers with raw or gzip data), each bad input with the message it must give, and
// TotalSegmentator's example segmentation and CT from ../shared/data.

namespace osteon {
namespace {
namespace volume_read_test {

namespace fs = std::filesystem;

// ---- writing volumes -------------------------------------------------------------------------

template <class T>
void append_value(std::string* out, T v, bool big) {
  using Bits = std::conditional_t<
      sizeof(T) == 1, uint8_t,
      std::conditional_t<sizeof(T) == 2, uint16_t,
                         std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>>>;
  Bits bits = std::bit_cast<Bits>(v);
  for (size_t i = 0; i < sizeof(T); ++i) {
    const size_t shift = 8 * (big ? sizeof(T) - 1 - i : i);
    out->push_back(static_cast<char>(static_cast<uint64_t>(bits) >> shift & 0xff));
  }
}

// One voxel type as each format names it.
struct TypeCase {
  const char* nrrd;
  int16_t nifti;  // NIfTI datatype code
  int bits;
  bool is_signed;
  bool is_float;
};

const std::vector<TypeCase>& type_cases() {
  static const std::vector<TypeCase> cases = {
      {"uchar", 2, 8, false, false},         {"signed char", 256, 8, true, false},
      {"ushort", 512, 16, false, false},     {"short", 4, 16, true, false},
      {"uint", 768, 32, false, false},       {"int", 8, 32, true, false},
      {"ulonglong", 1280, 64, false, false}, {"longlong", 1024, 64, true, false},
      {"float", 16, 32, true, true},         {"double", 64, 64, true, true},
  };
  return cases;
}

// The values as voxels of type `t`.
std::string encode(const TypeCase& t, const std::vector<double>& values, bool big) {
  std::string out;
  for (double v : values) {
    if (t.is_float) {
      t.bits == 32 ? append_value(&out, static_cast<float>(v), big) : append_value(&out, v, big);
    } else if (t.bits == 8) {
      t.is_signed ? append_value(&out, static_cast<int8_t>(v), big)
                  : append_value(&out, static_cast<uint8_t>(v), big);
    } else if (t.bits == 16) {
      t.is_signed ? append_value(&out, static_cast<int16_t>(v), big)
                  : append_value(&out, static_cast<uint16_t>(v), big);
    } else if (t.bits == 32) {
      t.is_signed ? append_value(&out, static_cast<int32_t>(v), big)
                  : append_value(&out, static_cast<uint32_t>(v), big);
    } else {
      t.is_signed ? append_value(&out, static_cast<int64_t>(v), big)
                  : append_value(&out, static_cast<uint64_t>(v), big);
    }
  }
  return out;
}

std::string gzip(const std::string& bytes) {
  z_stream z{};
  EXPECT_EQ(deflateInit2(&z, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY), Z_OK);
  std::string out(deflateBound(&z, bytes.size()) + 64, '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
  z.avail_in = static_cast<uInt>(bytes.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  EXPECT_EQ(deflate(&z, Z_FINISH), Z_STREAM_END);
  out.resize(z.total_out);
  deflateEnd(&z);
  return out;
}

// A NIfTI header's fields, written by hand at the offsets of nifti1.h / nifti2.h.
struct NiftiSpec {
  int version = 1;
  int16_t datatype = 2;
  int16_t bitpix = 8;
  std::array<int64_t, 8> dim{3, 4, 3, 2, 1, 1, 1, 1};
  std::array<double, 8> pixdim{1, 1, 1, 1, 0, 0, 0, 0};
  int qform_code = 0;
  int sform_code = 1;
  std::array<double, 6> quatern{0, 0, 0, 0, 0, 0};  // b, c, d, qoffset x, y, z
  double srow[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
  int xyz_units = 2;  // mm
  double slope = 0, inter = 0;
  std::string extension;  // the data of one code-0 extension
  bool big = false;
};

class HeaderWriter {
 public:
  HeaderWriter(size_t size, bool big) : bytes_(size, '\0'), big_(big) {}
  template <class T>
  void put(size_t offset, T v) {
    std::string b;
    append_value(&b, v, big_);
    std::memcpy(bytes_.data() + offset, b.data(), b.size());
  }
  void text(size_t offset, const char* s, size_t n) { std::memcpy(bytes_.data() + offset, s, n); }
  std::string bytes_;
  bool big_;
};

std::string nifti_bytes(const NiftiSpec& s, const std::string& voxels) {
  const size_t header = s.version == 1 ? 348 : 540;
  std::string ext;
  if (!s.extension.empty()) {
    const size_t esize = (s.extension.size() + 8 + 15) / 16 * 16;
    HeaderWriter e(esize, s.big);
    e.put<int32_t>(0, static_cast<int32_t>(esize));
    e.put<int32_t>(4, 0);
    e.text(8, s.extension.data(), s.extension.size());
    ext = e.bytes_;
  }
  const size_t vox_offset = header + 4 + ext.size();
  HeaderWriter h(header, s.big);
  if (s.version == 1) {
    h.put<int32_t>(0, 348);
    for (int i = 0; i < 8; ++i) h.put<int16_t>(40 + 2 * i, static_cast<int16_t>(s.dim[i]));
    h.put<int16_t>(70, s.datatype);
    h.put<int16_t>(72, s.bitpix);
    for (int i = 0; i < 8; ++i) h.put<float>(76 + 4 * i, static_cast<float>(s.pixdim[i]));
    h.put<float>(108, static_cast<float>(vox_offset));
    h.put<float>(112, static_cast<float>(s.slope));
    h.put<float>(116, static_cast<float>(s.inter));
    h.put<uint8_t>(123, static_cast<uint8_t>(s.xyz_units));
    h.put<int16_t>(252, static_cast<int16_t>(s.qform_code));
    h.put<int16_t>(254, static_cast<int16_t>(s.sform_code));
    for (int i = 0; i < 6; ++i) h.put<float>(256 + 4 * i, static_cast<float>(s.quatern[i]));
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c)
        h.put<float>(280 + 16 * r + 4 * c, static_cast<float>(s.srow[r][c]));
    }
    h.text(344, "n+1\0", 4);
  } else {
    h.put<int32_t>(0, 540);
    h.text(4, "n+2\0\r\n\032\n", 8);
    h.put<int16_t>(12, s.datatype);
    h.put<int16_t>(14, s.bitpix);
    for (int i = 0; i < 8; ++i) h.put<int64_t>(16 + 8 * i, s.dim[i]);
    for (int i = 0; i < 8; ++i) h.put<double>(104 + 8 * i, s.pixdim[i]);
    h.put<int64_t>(168, static_cast<int64_t>(vox_offset));
    h.put<double>(176, s.slope);
    h.put<double>(184, s.inter);
    h.put<int32_t>(344, s.qform_code);
    h.put<int32_t>(348, s.sform_code);
    for (int i = 0; i < 6; ++i) h.put<double>(352 + 8 * i, s.quatern[i]);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) h.put<double>(400 + 32 * r + 8 * c, s.srow[r][c]);
    }
    h.put<int32_t>(500, s.xyz_units);
  }
  std::string out = h.bytes_;
  out += ext.empty() ? std::string(4, '\0') : std::string("\1\0\0\0", 4);
  out += ext;
  return out + voxels;
}

NiftiSpec spec_for(const TypeCase& t) {
  NiftiSpec s;
  s.datatype = t.nifti;
  s.bitpix = static_cast<int16_t>(t.bits);
  return s;
}

std::string write_file(const std::string& dir, const std::string& name, const std::string& bytes) {
  const std::string path = dir + "/" + name;
  test::write_bytes(path, bytes);
  return path;
}

std::string read_error(const std::string& path, const VolumeReadOptions& options = {}) {
  auto volume = read_volume(path, options);
  if (volume.ok()) return "";
  EXPECT_EQ(volume.status().message().rfind(path + ": ", 0), 0u) << volume.status().message();
  return volume.status().message();
}

LabelVolume read_or_fail(const std::string& path, const VolumeReadOptions& options = {}) {
  auto volume = read_volume(path, options);
  if (!volume.ok()) {
    ADD_FAILURE() << volume.status().message();
    return {};
  }
  return std::move(volume).value();
}

// The label value of every voxel.
std::vector<uint32_t> label_values(const LabelVolume& v) {
  std::vector<uint32_t> out(v.voxel_count());
  for (size_t i = 0; i < out.size(); ++i) out[i] = v.values.at(v.id(i));
  return out;
}

// Checks what every LabelVolume promises: sizes, ids in range, a sorted table that counts them.
void expect_consistent(const LabelVolume& v) {
  ASSERT_EQ(v.voxels.size(), v.voxel_count() * v.bytes_per_voxel);
  ASSERT_FALSE(v.values.empty());
  EXPECT_EQ(v.values[0], 0u);
  std::map<uint32_t, uint64_t> counts;
  for (size_t i = 0; i < v.voxel_count(); ++i) {
    ASSERT_LT(v.id(i), v.values.size());
    if (v.id(i) != 0) ++counts[v.values[v.id(i)]];
  }
  for (size_t i = 0; i < v.table.size(); ++i) {
    if (i > 0) {
      EXPECT_LT(v.table[i - 1].value, v.table[i].value);
    }
    EXPECT_EQ(v.table[i].voxels, counts.count(v.table[i].value) ? counts[v.table[i].value] : 0u)
        << v.table[i].value;
  }
  for (const auto& [value, count] : counts) {
    bool listed = false;
    for (const VolumeLabel& label : v.table) listed = listed || label.value == value;
    EXPECT_TRUE(listed) << value;
  }
}

bool has_note(const LabelVolume& v, const std::string& text) {
  for (const std::string& note : v.notes) {
    if (note.find(text) != std::string::npos) return true;
  }
  return false;
}

const VolumeLabel* find_label(const LabelVolume& v, const std::string& name) {
  for (const VolumeLabel& label : v.table) {
    if (label.name == name) return &label;
  }
  return nullptr;
}

void expect_world(const LabelVolume& v, const Vec3d& ijk, const Vec3d& expected,
                  double tolerance = 1e-4) {
  Vec3d p = transform_point(v.index_to_world, ijk);
  EXPECT_NEAR(p.x, expected.x, tolerance);
  EXPECT_NEAR(p.y, expected.y, tolerance);
  EXPECT_NEAR(p.z, expected.z, tolerance);
}

// 4 x 3 x 2 labels, each value of {0, 1, 2, 7, 100} several times.
const std::vector<double>& small_labels() {
  static const std::vector<double> labels = {0,   1, 2, 7, 100, 0, 0, 1, 1, 2, 7,   7,
                                             100, 0, 2, 2, 1,   0, 0, 0, 7, 1, 100, 2};
  return labels;
}

std::vector<uint32_t> as_uint(const std::vector<double>& values) {
  return std::vector<uint32_t>(values.begin(), values.end());
}

// ---- NIfTI ----------------------------------------------------------------------------------

TEST(VolumeReadNifti, EveryTypeBothByteOrdersPlainAndGzip) {
  const std::string dir = test::scratch_dir();
  for (const TypeCase& t : type_cases()) {
    for (bool big : {false, true}) {
      for (bool gz : {false, true}) {
        SCOPED_TRACE(std::string(t.nrrd) + (big ? " big" : " little") + (gz ? " gzip" : ""));
        NiftiSpec s = spec_for(t);
        s.big = big;
        std::string bytes = nifti_bytes(s, encode(t, small_labels(), big));
        const std::string path =
            write_file(dir, gz ? "v.nii.gz" : "v.nii", gz ? gzip(bytes) : bytes);
        LabelVolume v = read_or_fail(path);
        EXPECT_EQ(v.size, (std::array<uint32_t, 3>{4, 3, 2}));
        EXPECT_EQ(label_values(v), as_uint(small_labels()));
        EXPECT_EQ(v.bytes_per_voxel, 1);
        ASSERT_EQ(v.table.size(), 4u);
        EXPECT_EQ(v.table[0].value, 1u);
        EXPECT_EQ(v.table[0].voxels, 5u);
        EXPECT_EQ(v.table[3].value, 100u);
        EXPECT_EQ(v.source, path);
        expect_consistent(v);
      }
    }
  }
}

TEST(VolumeReadNifti, Nifti2) {
  const std::string dir = test::scratch_dir();
  const TypeCase& t = type_cases()[3];  // int16
  NiftiSpec s = spec_for(t);
  s.version = 2;
  s.srow[0][3] = 10;
  const std::string path =
      write_file(dir, "v2.nii", nifti_bytes(s, encode(t, small_labels(), false)));
#if defined(OSTEON_NIFTI2)
  LabelVolume v = read_or_fail(path);
  EXPECT_EQ(label_values(v), as_uint(small_labels()));
  expect_world(v, {1, 1, 1}, {-11, -1, 1});
  // And gzip, big-endian.
  s.big = true;
  const std::string gz =
      write_file(dir, "v2.nii.gz", gzip(nifti_bytes(s, encode(t, small_labels(), true))));
  EXPECT_EQ(label_values(read_or_fail(gz)), as_uint(small_labels()));
#else
  auto v = read_volume(path);
  ASSERT_FALSE(v.ok());
  EXPECT_EQ(v.status().code(), ErrorCode::kUnsupported);
  EXPECT_NE(v.status().message().find("NIfTI-2"), std::string::npos) << v.status().message();
#endif
}

TEST(VolumeReadNifti, SformIsRasMadeLps) {
  const std::string dir = test::scratch_dir();
  NiftiSpec s;
  s.sform_code = 2;
  s.srow[0][0] = 2, s.srow[1][1] = 3, s.srow[2][2] = 4;
  s.srow[0][3] = 10, s.srow[1][3] = 20, s.srow[2][3] = 30;
  s.qform_code = 1;  // the sform wins
  s.quatern = {0, 0, 0, 99, 99, 99};
  const std::string path =
      write_file(dir, "s.nii", nifti_bytes(s, encode(type_cases()[0], small_labels(), false)));
  LabelVolume v = read_or_fail(path);
  expect_world(v, {0, 0, 0}, {-10, -20, 30});
  expect_world(v, {3, 2, 1}, {-16, -26, 34});
  EXPECT_GT(determinant3(v.index_to_world), 0);
}

TEST(VolumeReadNifti, QformWithoutSform) {
  const std::string dir = test::scratch_dir();
  NiftiSpec s;
  s.sform_code = 0;
  s.qform_code = 1;
  s.pixdim = {1, 2, 2, 2, 0, 0, 0, 0};
  s.quatern = {0, 0, 0, 5, 6, 7};
  const std::string path =
      write_file(dir, "q.nii", nifti_bytes(s, encode(type_cases()[0], small_labels(), false)));
  LabelVolume v = read_or_fail(path);
  expect_world(v, {1, 1, 1}, {-7, -8, 9});
  EXPECT_TRUE(v.notes.empty());
}

TEST(VolumeReadNifti, PixdimAloneIsNoted) {
  const std::string dir = test::scratch_dir();
  NiftiSpec s;
  s.sform_code = 0;
  s.pixdim = {1, 0.5, 0.5, 3, 0, 0, 0, 0};
  const std::string path =
      write_file(dir, "p.nii", nifti_bytes(s, encode(type_cases()[0], small_labels(), false)));
  LabelVolume v = read_or_fail(path);
  expect_world(v, {2, 2, 1}, {-1, -1, 3});
  EXPECT_TRUE(has_note(v, "pixdim alone")) << ::testing::PrintToString(v.notes);
}

TEST(VolumeReadNifti, LengthUnitsBecomeMillimetres) {
  const std::string dir = test::scratch_dir();
  NiftiSpec s;
  s.srow[0][0] = s.srow[1][1] = s.srow[2][2] = 0.002;
  s.srow[2][3] = 0.1;
  s.xyz_units = 1;  // metres
  const std::string voxels = encode(type_cases()[0], small_labels(), false);
  LabelVolume v = read_or_fail(write_file(dir, "m.nii", nifti_bytes(s, voxels)));
  expect_world(v, {1, 1, 1}, {-2, -2, 102});
  s.srow[0][0] = s.srow[1][1] = s.srow[2][2] = 500;
  s.srow[2][3] = 0;
  s.xyz_units = 3;  // micrometres
  v = read_or_fail(write_file(dir, "um.nii", nifti_bytes(s, voxels)));
  expect_world(v, {1, 1, 1}, {-0.5, -0.5, 0.5});
}

std::string caret_table(const std::string& labels) {
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<CaretExtension>\n<Date><![CDATA[2024]]>"
         "</Date>\n<VolumeInformation Index=\"0\">\n<LabelTable>\n" +
         labels + "</LabelTable>\n</VolumeInformation>\n</CaretExtension>\n";
}

TEST(VolumeReadNifti, CaretLabelTable) {
  const std::string dir = test::scratch_dir();
  NiftiSpec s;
  s.extension = caret_table(
      "<Label Key=\"0\" Red=\"0\" Green=\"0\" Blue=\"0\" Alpha=\"0\"><![CDATA[???]]></Label>\n"
      "<Label Key=\"1\" Red=\"0.0\" Green=\"1.0\" Blue=\"0.0\" "
      "Alpha=\"1\"><![CDATA[spleen]]></Label>\n"
      "<!-- a comment -->\n"
      "<Label Key='2' Red='1' Green='0.5' Blue='0.25' Alpha='1'> rib &amp; &lt;cartilage&gt; "
      "&quot;x&quot; &apos;y&apos; &#233;</Label>\n"
      "<Label Key=\"7\">plain<![CDATA[ & raw]]></Label>\n"
      "<Label Key=\"55\" Red=\"0.1\" Green=\"0.2\" Blue=\"0.3\" "
      "Alpha=\"1\"><![CDATA[absent]]></Label>\n");
  const std::string path = write_file(
      dir, "t.nii.gz", gzip(nifti_bytes(s, encode(type_cases()[0], small_labels(), false))));
  LabelVolume v = read_or_fail(path);
  expect_consistent(v);
  ASSERT_EQ(v.table.size(), 5u);  // 1, 2, 7, 55 named; 100 present
  EXPECT_EQ(v.table[0].name, "spleen");
  EXPECT_TRUE(v.table[0].has_color);
  EXPECT_EQ(v.table[0].color, (Vec3{0, 1, 0}));
  EXPECT_EQ(v.table[1].name, "rib & <cartilage> \"x\" 'y' \xc3\xa9");
  EXPECT_EQ(v.table[1].color, (Vec3{1, 0.5f, 0.25f}));
  EXPECT_EQ(v.table[2].name, "plain & raw");
  EXPECT_FALSE(v.table[2].has_color);
  EXPECT_EQ(v.table[3].value, 55u);
  EXPECT_EQ(v.table[3].name, "absent");
  EXPECT_EQ(v.table[3].voxels, 0u);
  EXPECT_EQ(v.table[4].value, 100u);
  EXPECT_EQ(v.table[4].name, "");
  EXPECT_EQ(v.table[4].voxels, 3u);
}

TEST(VolumeReadNifti, LabelTableErrors) {
  const std::string dir = test::scratch_dir();
  const std::string voxels = encode(type_cases()[0], small_labels(), false);
  struct Case {
    std::string labels;
    std::string message;
  };
  const Case cases[] = {
      {"<Label Key=\"1\">liver</Label><Label Key=\"2\">liver</Label>", "one name, \"liver\""},
      {"<Label Key=\"1\">liver</Label><Label Key=\"1\">spleen</Label>", "Key 1 has two"},
      {"<Label Key=\"x\">liver</Label>", "not an integer"},
      {"<Label Red=\"1\">liver</Label>", "without a Key"},
      {"<Label Key=\"1\" Red=\"2\" Green=\"0\" Blue=\"0\">liver</Label>", "Red=\"2\""},
      {"<Label Key=\"1\">liver", "without </Label>"},
      {"<Label Key=\"1\"><![CDATA[liver</Label>", "CDATA"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.labels);
    NiftiSpec s;
    s.extension = caret_table(c.labels);
    const std::string message = read_error(write_file(dir, "bad.nii", nifti_bytes(s, voxels)));
    EXPECT_NE(message.find(c.message), std::string::npos) << message;
    EXPECT_NE(message.find("NIfTI extension 0"), std::string::npos) << message;
  }
}

TEST(VolumeReadNifti, FourDReadsTheFirstVolume) {
  const std::string dir = test::scratch_dir();
  NiftiSpec s;
  s.dim = {4, 4, 3, 2, 3, 1, 1, 1};
  std::vector<double> all = small_labels();
  for (int t = 1; t < 3; ++t) {
    for (size_t i = 0; i < 24; ++i) all.push_back(200 + t);
  }
  LabelVolume v =
      read_or_fail(write_file(dir, "4d.nii", nifti_bytes(s, encode(type_cases()[0], all, false))));
  EXPECT_EQ(label_values(v), as_uint(small_labels()));
  EXPECT_TRUE(has_note(v, "4-D volume: the first of 3 volumes is read"))
      << ::testing::PrintToString(v.notes);
}

TEST(VolumeReadNifti, WidensPast255Labels) {
  const std::string dir = test::scratch_dir();
  NiftiSpec s = spec_for(type_cases()[2]);  // uint16
  s.dim = {3, 20, 20, 2, 1, 1, 1, 1};
  std::vector<double> values(800);
  for (size_t i = 0; i < values.size(); ++i) values[i] = static_cast<double>((i * 7) % 300);
  LabelVolume v = read_or_fail(
      write_file(dir, "w.nii.gz", gzip(nifti_bytes(s, encode(type_cases()[2], values, false)))));
  EXPECT_EQ(v.bytes_per_voxel, 2);
  EXPECT_EQ(v.values.size(), 300u);
  EXPECT_EQ(label_values(v), as_uint(values));
  expect_consistent(v);
}

TEST(VolumeReadNifti, LargeVolumeStreamsInSlabs) {
  // 5 MB of int16 labels: two slabs; gzip reserved from its trailer.
  const std::string dir = test::scratch_dir();
  NiftiSpec s = spec_for(type_cases()[3]);
  s.dim = {3, 256, 256, 40, 1, 1, 1, 1};
  std::vector<double> values(256 * 256 * 40);
  for (size_t i = 0; i < values.size(); ++i) values[i] = static_cast<double>(i / 65536 % 17);
  const std::string bytes = nifti_bytes(s, encode(type_cases()[3], values, false));
  for (bool gz : {false, true}) {
    LabelVolume v =
        read_or_fail(write_file(dir, gz ? "l.nii.gz" : "l.nii", gz ? gzip(bytes) : bytes));
    ASSERT_EQ(v.voxel_count(), values.size());
    EXPECT_EQ(label_values(v), as_uint(values));
    EXPECT_EQ(v.table.size(), 16u);
  }
}

TEST(VolumeReadNifti, IntensityVolumesAreRefused) {
  const std::string dir = test::scratch_dir();
  const TypeCase& i16 = type_cases()[3];
  std::vector<double> values = small_labels();
  values[5] = -5;
  values[6] = 9;
  std::string message =
      read_error(write_file(dir, "ct.nii", nifti_bytes(spec_for(i16), encode(i16, values, false))));
  EXPECT_NE(message.find("an intensity volume (int16 values from -5 to 100"), std::string::npos)
      << message;
  EXPECT_NE(message.find("not a label volume: give --threshold"), std::string::npos) << message;

  const TypeCase& f32 = type_cases()[8];
  values = small_labels();
  values[3] = 2.5;
  message =
      read_error(write_file(dir, "f.nii", nifti_bytes(spec_for(f32), encode(f32, values, false))));
  EXPECT_NE(message.find("not integers"), std::string::npos) << message;

  // Over 4096 distinct values: intensity without a label table, labels with one.
  const TypeCase& u16 = type_cases()[2];
  NiftiSpec s = spec_for(u16);
  s.dim = {3, 100, 50, 1, 1, 1, 1, 1};
  values.assign(5000, 0);
  for (size_t i = 0; i < values.size(); ++i) values[i] = static_cast<double>(i + 1);
  message = read_error(write_file(dir, "many.nii", nifti_bytes(s, encode(u16, values, false))));
  EXPECT_NE(message.find("more than 4096 distinct values"), std::string::npos) << message;
  s.extension = caret_table("<Label Key=\"1\">one</Label>");
  LabelVolume v =
      read_or_fail(write_file(dir, "named.nii", nifti_bytes(s, encode(u16, values, false))));
  EXPECT_EQ(v.values.size(), 5001u);
  EXPECT_EQ(v.table.size(), 5000u);
  EXPECT_EQ(v.table[0].name, "one");
}

TEST(VolumeReadNifti, ThresholdMakesBone) {
  const std::string dir = test::scratch_dir();
  const TypeCase& i16 = type_cases()[3];
  NiftiSpec s = spec_for(i16);
  s.slope = 2;
  s.inter = -100;
  std::vector<double> values(24);
  for (size_t i = 0; i < values.size(); ++i) values[i] = static_cast<double>(i) * 10 - 40;
  const std::string path =
      write_file(dir, "ct.nii.gz", gzip(nifti_bytes(s, encode(i16, values, false))));
  VolumeReadOptions options;
  options.threshold = 250;  // value * 2 - 100 >= 250: value >= 175
  LabelVolume v = read_or_fail(path, options);
  expect_consistent(v);
  std::vector<uint32_t> expected(24);
  for (size_t i = 0; i < 24; ++i) expected[i] = values[i] >= 175 ? 1 : 0;
  EXPECT_EQ(label_values(v), expected);
  ASSERT_EQ(v.table.size(), 1u);
  EXPECT_EQ(v.table[0].name, "bone");
  EXPECT_EQ(v.table[0].voxels, 2u);  // 180 and 190
  EXPECT_TRUE(has_note(v, ">= 250")) << ::testing::PrintToString(v.notes);

  // A label volume is read as labels, the threshold noted as unused.
  LabelVolume labels = read_or_fail(
      write_file(dir, "l.nii", nifti_bytes(spec_for(i16), encode(i16, small_labels(), false))),
      options);
  EXPECT_EQ(label_values(labels), as_uint(small_labels()));
  EXPECT_TRUE(has_note(labels, "not applied"));
}

TEST(VolumeReadNifti, BadInputs) {
  const std::string dir = test::scratch_dir();
  const TypeCase& u8 = type_cases()[0];
  const std::string good = nifti_bytes(NiftiSpec{}, encode(u8, small_labels(), false));
  struct Case {
    std::string name;
    std::string bytes;
    std::string message;
    ErrorCode code = ErrorCode::kInvalidData;
  };
  std::vector<Case> cases;
  cases.push_back({"short.nii", good.substr(0, good.size() - 5), "the file holds 19"});
  const std::string gz = gzip(good);
  cases.push_back({"cut.nii.gz", gz.substr(0, gz.size() - 12), "truncated gzip"});
  std::string corrupt = gz;
  corrupt[corrupt.size() - 6] = static_cast<char>(~corrupt[corrupt.size() - 6]);  // the CRC
  cases.push_back({"corrupt.nii.gz", corrupt, "corrupt gzip data (zlib: incorrect data check)"});
  {
    NiftiSpec s;
    s.dim = {3, 1000, 1000, 1000, 1, 1, 1, 1};
    cases.push_back({"huge.nii", nifti_bytes(s, "abc"), "1000 x 1000 x 1000 voxels"});
    cases.push_back(
        {"huge.nii.gz", gzip(nifti_bytes(s, std::string(2000, '\0'))), "decodes to at most"});
  }
  for (double bad : {0.0, -1.0, std::nan("")}) {
    NiftiSpec s;
    s.sform_code = 0;
    s.qform_code = 1;
    s.pixdim[2] = bad;
    cases.push_back({"pixdim.nii", nifti_bytes(s, encode(u8, small_labels(), false)),
                     "voxel sizes must be positive (pixdim[2])"});
  }
  {
    NiftiSpec s;
    s.srow[1][1] = 0;
    cases.push_back(
        {"zero.nii", nifti_bytes(s, encode(u8, small_labels(), false)), "zero voxel size along j"});
    s.srow[0][1] = 1;  // axes i and j both along (1, 1, 0)
    s.srow[1][0] = 1;
    s.srow[1][1] = 1;
    cases.push_back(
        {"singular.nii", nifti_bytes(s, encode(u8, small_labels(), false)), "singular"});
    s = NiftiSpec{};
    s.srow[2][3] = std::nan("");
    cases.push_back({"nan.nii", nifti_bytes(s, encode(u8, small_labels(), false)), "NaN"});
  }
  {
    NiftiSpec s;
    s.datatype = 128;  // RGB24
    s.bitpix = 24;
    cases.push_back({"rgb.nii", nifti_bytes(s, std::string(72, '\1')), "datatype 128",
                     ErrorCode::kUnsupported});
  }
  cases.push_back({"text.nii", "not a nifti file at all, just some text that is long enough.",
                   "not a NIfTI-1 or NIfTI-2 file"});
  cases.push_back({"ascii.nii", "<nifti_image\n  nx = '4'\n/>\n" + std::string(400, ' '),
                   "an ASCII NIfTI header", ErrorCode::kUnsupported});
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = write_file(dir, c.name, c.bytes);
    auto v = read_volume(path);
    ASSERT_FALSE(v.ok());
    EXPECT_EQ(v.status().code(), c.code);
    EXPECT_NE(v.status().message().find(c.message), std::string::npos) << v.status().message();
    EXPECT_EQ(v.status().message().rfind(path + ": ", 0), 0u) << v.status().message();
  }

  // The caller's memory limit; a missing file.
  VolumeReadOptions small;
  small.max_voxel_bytes = 10;
  EXPECT_NE(read_error(write_file(dir, "ok.nii", good), small).find("max_voxel_bytes"),
            std::string::npos);
  auto missing = read_volume(dir + "/missing.nii");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().code(), ErrorCode::kIoError);
}

// ---- NRRD -----------------------------------------------------------------------------------

std::string nrrd_header(const std::string& fields) {
  return "NRRD0004\n# written by the test\n" + fields;
}

TEST(VolumeReadNrrd, EveryTypeBothEndiansRawAndGzip) {
  const std::string dir = test::scratch_dir();
  for (const TypeCase& t : type_cases()) {
    for (bool big : {false, true}) {
      for (bool gz : {false, true}) {
        SCOPED_TRACE(std::string(t.nrrd) + (big ? " big" : " little") + (gz ? " gzip" : ""));
        const std::string data = encode(t, small_labels(), big);
        const std::string header =
            nrrd_header(std::string("type: ") + t.nrrd +
                        "\ndimension: 3\nsizes: 4 3 2\nencoding: " + (gz ? "gzip" : "raw") +
                        "\nendian: " + (big ? "big" : "little") +
                        "\nspace: left-posterior-superior\n"
                        "space directions: (1,0,0) (0,1,0) (0,0,1)\n"
                        "space origin: (0,0,0)\n\n");
        LabelVolume v = read_or_fail(write_file(dir, "v.nrrd", header + (gz ? gzip(data) : data)));
        EXPECT_EQ(v.size, (std::array<uint32_t, 3>{4, 3, 2}));
        EXPECT_EQ(label_values(v), as_uint(small_labels()));
        expect_consistent(v);
      }
    }
  }
}

TEST(VolumeReadNrrd, DetachedHeader) {
  const std::string dir = test::scratch_dir();
  const std::string data = encode(type_cases()[3], small_labels(), false);
  fs::create_directories(dir + "/data");
  write_file(dir, "data/v.raw", data);
  write_file(dir, "v.raw.gz", gzip(data));
  const std::string base =
      "type: short\ndimension: 3\nsizes: 4 3 2\nendian: little\nspacings: 1 1 1\n";
  for (const std::string& tail : {std::string("encoding: raw\ndata file: data/v.raw\n"),
                                  std::string("encoding: raw\ndatafile: ./data/v.raw\n"),
                                  std::string("encoding: gzip\ndata file: v.raw.gz\n")}) {
    SCOPED_TRACE(tail);
    LabelVolume v = read_or_fail(write_file(dir, "v.nhdr", nrrd_header(base + tail)));
    EXPECT_EQ(label_values(v), as_uint(small_labels()));
  }
  // A .nrrd may name a data file too.
  LabelVolume v = read_or_fail(write_file(
      dir, "named.nrrd", nrrd_header(base + "encoding: raw\ndata file: data/v.raw\n\n")));
  EXPECT_EQ(label_values(v), as_uint(small_labels()));
}

TEST(VolumeReadNrrd, DetachedDataOutsideTheFolderIsRefused) {
  const std::string root = test::scratch_dir();
  const std::string dir = root + "/inner";
  fs::create_directories(dir);
  const std::string data = encode(type_cases()[0], small_labels(), false);
  write_file(root, "outside.raw", data);
  fs::create_symlink(root + "/outside.raw", dir + "/link.raw");
  const std::string base = "type: uchar\ndimension: 3\nsizes: 4 3 2\nencoding: raw\n";
  const std::pair<std::string, std::string> cases[] = {
      {"../outside.raw", "climbs out"},         {"sub/../../outside.raw", "climbs out"},
      {root + "/outside.raw", "absolute path"}, {"link.raw", "resolves outside"},
      {"img%03d.raw 1 3 1", "several files"},
  };
  for (const auto& [name, message] : cases) {
    SCOPED_TRACE(name);
    const std::string error =
        read_error(write_file(dir, "v.nhdr", nrrd_header(base + "data file: " + name + "\n")));
    EXPECT_NE(error.find(message), std::string::npos) << error;
    EXPECT_NE(error.find("(data file)"), std::string::npos) << error;
  }
}

TEST(VolumeReadNrrd, RasAndLpsGiveTheSameWorld) {
  const std::string dir = test::scratch_dir();
  const std::string data = encode(type_cases()[0], small_labels(), false);
  const std::string base = "type: uchar\ndimension: 3\nsizes: 4 3 2\nencoding: raw\n";
  LabelVolume lps = read_or_fail(
      write_file(dir, "lps.nrrd",
                 nrrd_header(base + "space: LPS\nspace directions: (0.5,0,0) (0,2,0) (0,0.2,3)\n"
                                    "space origin: (10,20,5)\n\n") +
                     data));
  LabelVolume ras = read_or_fail(
      write_file(dir, "ras.nrrd",
                 nrrd_header(base + "space: right-anterior-superior\n"
                                    "space directions: (-0.5,0,0) (0,-2,0) (0,-0.2,3)\n"
                                    "space origin: (-10,-20,5)\n\n") +
                     data));
  for (int i = 0; i < 16; ++i)
    EXPECT_NEAR(lps.index_to_world[i], ras.index_to_world[i], 1e-12) << i;
  expect_world(lps, {3, 2, 1}, {11.5, 24.2, 8});
  EXPECT_TRUE(lps.notes.empty()) << ::testing::PrintToString(lps.notes);
}

TEST(VolumeReadNrrd, SpacingsAloneAreNoted) {
  const std::string dir = test::scratch_dir();
  LabelVolume v = read_or_fail(write_file(
      dir, "s.nrrd",
      nrrd_header("type: uchar\ndimension: 3\nsizes: 4 3 2\nencoding: raw\nspacings: 2 3 4\n\n") +
          encode(type_cases()[0], small_labels(), false)));
  expect_world(v, {1, 1, 1}, {2, 3, 4});
  EXPECT_TRUE(has_note(v, "spacings alone")) << ::testing::PrintToString(v.notes);
}

TEST(VolumeReadNrrd, ByteAndLineSkip) {
  const std::string dir = test::scratch_dir();
  const std::string data = encode(type_cases()[2], small_labels(), true);
  write_file(dir, "skip.raw", "line one\nline two\n" + std::string(6, 'x') + data);
  write_file(dir, "tail.raw", std::string(33, 'y') + data);
  write_file(dir, "skip.raw.gz", gzip(std::string(6, 'x') + data));
  const std::string base = "type: ushort\ndimension: 3\nsizes: 4 3 2\nendian: big\n";
  for (const std::string& tail :
       {std::string("encoding: raw\ndata file: skip.raw\nline skip: 2\nbyte skip: 6\n"),
        std::string("encoding: raw\ndata file: tail.raw\nbyte skip: -1\n"),
        std::string("encoding: gzip\ndata file: skip.raw.gz\nbyte skip: 6\n")}) {
    SCOPED_TRACE(tail);
    LabelVolume v = read_or_fail(write_file(dir, "v.nhdr", nrrd_header(base + tail)));
    EXPECT_EQ(label_values(v), as_uint(small_labels()));
  }
}

TEST(VolumeReadNrrd, FourDReadsTheFirstVolume) {
  const std::string dir = test::scratch_dir();
  std::vector<double> all = small_labels();
  for (size_t i = 0; i < 48; ++i) all.push_back(9);
  LabelVolume v = read_or_fail(
      write_file(dir, "t.nrrd",
                 nrrd_header("type: uchar\ndimension: 4\nsizes: 4 3 2 3\nencoding: raw\n"
                             "kinds: domain domain domain time\nspace: LPS\n"
                             "space directions: (1,0,0) (0,1,0) (0,0,1) none\n\n") +
                     encode(type_cases()[0], all, false)));
  EXPECT_EQ(label_values(v), as_uint(small_labels()));
  EXPECT_TRUE(has_note(v, "4-D volume: the first of 3 volumes is read"));
}

std::string segment_keys(int n, const std::string& name, const std::string& color, int value,
                         int layer) {
  const std::string p = "Segment" + std::to_string(n) + "_";
  return p + "ID:=Segment_" + std::to_string(n) + "\n" + p + "Name:=" + name + "\n" + p +
         "Color:=" + color + "\n" + p + "LabelValue:=" + std::to_string(value) + "\n" + p +
         "Layer:=" + std::to_string(layer) + "\n" + p + "Extent:=0 3 0 2 0 1\n";
}

TEST(VolumeReadNrrd, SlicerSegmentationOneLayer) {
  const std::string dir = test::scratch_dir();
  const std::string keys = segment_keys(0, "femur", "0.9 0.8 0.7", 1, 0) +
                           segment_keys(1, "tibia", "0.1 0.2 0.3", 2, 0) +
                           segment_keys(2, "patella", "1 1 1", 50, 0) +
                           "Segmentation_MasterRepresentation:=Binary labelmap\n";
  LabelVolume v = read_or_fail(write_file(
      dir, "knee.seg.nrrd",
      nrrd_header("type: uchar\ndimension: 3\nspace: left-posterior-superior\nsizes: 4 3 2\n"
                  "space directions: (1,0,0) (0,1,0) (0,0,1)\nkinds: domain domain domain\n"
                  "encoding: gzip\nspace origin: (0,0,0)\n" +
                  keys + "\n") +
          gzip(encode(type_cases()[0], small_labels(), false))));
  expect_consistent(v);
  const VolumeLabel* femur = find_label(v, "femur");
  ASSERT_NE(femur, nullptr);
  EXPECT_EQ(femur->value, 1u);
  EXPECT_EQ(femur->voxels, 5u);
  EXPECT_EQ(femur->color, (Vec3{0.9f, 0.8f, 0.7f}));
  const VolumeLabel* patella = find_label(v, "patella");
  ASSERT_NE(patella, nullptr);
  EXPECT_EQ(patella->voxels, 0u);
  EXPECT_EQ(v.table.size(), 5u);  // 1, 2, 7, 50, 100
}

TEST(VolumeReadNrrd, SlicerSegmentationLayers) {
  // Two layers; layer 1 reuses label value 1, so segments are numbered in order; voxels where
  // both layers hold a segment take layer 0's.
  const std::string dir = test::scratch_dir();
  const std::string keys = segment_keys(0, "skin", "1 0 0", 1, 0) +
                           segment_keys(1, "bone", "0 1 0", 2, 0) +
                           segment_keys(2, "tumour", "0 0 1", 1, 1);
  std::vector<double> layer0 = {0, 1, 1, 2, 2, 0, 0, 0}, layer1 = {1, 1, 0, 1, 0, 0, 0, 1};
  std::vector<double> interleaved;
  for (size_t i = 0; i < layer0.size(); ++i) {
    interleaved.push_back(layer0[i]);
    interleaved.push_back(layer1[i]);
  }
  LabelVolume v = read_or_fail(write_file(
      dir, "layers.seg.nrrd",
      nrrd_header("type: short\nendian: little\ndimension: 4\nspace: RAS\nsizes: 2 2 2 2\n"
                  "space directions: none (1,0,0) (0,1,0) (0,0,1)\n"
                  "kinds: list domain domain domain\nencoding: raw\nspace origin: (0,0,0)\n" +
                  keys + "\n") +
          encode(type_cases()[3], interleaved, false)));
  expect_consistent(v);
  EXPECT_EQ(v.size, (std::array<uint32_t, 3>{2, 2, 2}));
  EXPECT_EQ(label_values(v), (std::vector<uint32_t>{3, 1, 1, 2, 2, 0, 0, 3}));
  ASSERT_EQ(v.table.size(), 3u);
  EXPECT_EQ(v.table[2].name, "tumour");
  EXPECT_EQ(v.table[2].voxels, 2u);
  EXPECT_TRUE(has_note(v, "2 voxels belong to segments of two or more layers"))
      << ::testing::PrintToString(v.notes);
  EXPECT_TRUE(has_note(v, "numbered 1 to 3"));
  expect_world(v, {1, 1, 1}, {-1, -1, 1});
}

TEST(VolumeReadNrrd, SlicerSegmentErrors) {
  const std::string dir = test::scratch_dir();
  const std::string head =
      "type: uchar\ndimension: 3\nsizes: 4 3 2\nencoding: raw\nspace: LPS\n"
      "space directions: (1,0,0) (0,1,0) (0,0,1)\n";
  const std::string data = encode(type_cases()[0], small_labels(), false);
  const std::pair<std::string, std::string> cases[] = {
      {segment_keys(0, "rib", "1 0 0", 1, 0) + segment_keys(1, "rib", "1 0 0", 2, 0),
       "one name, \"rib\" (Segment1_Name)"},
      {segment_keys(0, "a", "1 0 0", 1, 0) + segment_keys(1, "b", "1 0 0", 1, 0),
       "(Segment1_LabelValue)"},
      {segment_keys(0, "a", "1 0", 1, 0), "(Segment0_Color)"},
      {segment_keys(0, "a", "1 0 0", 1, 2), "(Segment0_Layer)"},
  };
  for (const auto& [keys, message] : cases) {
    SCOPED_TRACE(message);
    const std::string error =
        read_error(write_file(dir, "s.seg.nrrd", nrrd_header(head + keys + "\n") + data));
    EXPECT_NE(error.find(message), std::string::npos) << error;
  }
}

TEST(VolumeReadNrrd, BadInputs) {
  const std::string dir = test::scratch_dir();
  const std::string data = encode(type_cases()[0], small_labels(), false);
  const std::string base = "type: uchar\ndimension: 3\nsizes: 4 3 2\n";
  struct Case {
    std::string name;
    std::string bytes;
    std::string message;
    ErrorCode code = ErrorCode::kInvalidData;
  };
  const std::vector<Case> cases = {
      {"bz.nrrd", nrrd_header(base + "encoding: bzip2\n\n") + data, "encoding",
       ErrorCode::kUnsupported},
      {"nosizes.nrrd", nrrd_header("type: uchar\ndimension: 3\nencoding: raw\n\n") + data,
       "no \"sizes\" field (sizes)"},
      {"short.nrrd", nrrd_header(base + "encoding: raw\n\n") + data.substr(0, 20), "(sizes)"},
      {"huge.nrrd",
       nrrd_header("type: uchar\ndimension: 3\nsizes: 1000 1000 1000\nencoding: raw\n\n") + data,
       "1000 x 1000 x 1000 voxels"},
      {"hugegz.nrrd",
       nrrd_header("type: uchar\ndimension: 3\nsizes: 1000 1000 1000\nencoding: gzip\n\n") +
           gzip(std::string(5000, '\0')),
       "decodes to at most"},
      {"cut.nrrd", nrrd_header(base + "encoding: gzip\n\n") + gzip(data).substr(0, 20), "gzip"},
      {"notgz.nrrd", nrrd_header(base + "encoding: gzip\n\n") + data, "not a gzip stream"},
      {"zero.nrrd",
       nrrd_header(base +
                   "encoding: raw\nspace: LPS\nspace directions: (1,0,0) (0,0,0) (0,0,1)\n\n") +
           data,
       "zero voxel size along j (space directions)"},
      {"nan.nrrd",
       nrrd_header(base + "encoding: raw\nspace: LPS\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n"
                          "space origin: (nan,0,0)\n\n") +
           data,
       "NaN"},
      {"negative.nrrd", nrrd_header(base + "encoding: raw\nspacings: 1 -1 1\n\n") + data,
       "voxel sizes must be positive (spacings)"},
      {"gzskip.nrrd", nrrd_header(base + "encoding: gzip\nbyte skip: -1\n\n") + gzip(data),
       "raw data only (byte skip)"},
      {"noblank.nrrd", nrrd_header(base + "encoding: raw\n"), "blank line"},
      {"nodata.nhdr", nrrd_header(base + "encoding: raw\n"), "without a data file field"},
      {"twice.nrrd", nrrd_header(base + "encoding: raw\nencoding: raw\n\n") + data, "given twice"},
      {"dim2.nrrd", nrrd_header("type: uchar\ndimension: 2\nsizes: 4 6\nencoding: raw\n\n") + data,
       "dimension 2", ErrorCode::kUnsupported},
      {"magic.nrrd", "NRRX0004\n" + base + "\n" + data, "no NRRD000x magic"},
      {"space.nrrd", nrrd_header(base + "encoding: raw\nspace: RAST\n\n") + data, "space \"RAST\"",
       ErrorCode::kUnsupported},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = write_file(dir, c.name, c.bytes);
    auto v = read_volume(path);
    ASSERT_FALSE(v.ok());
    EXPECT_EQ(v.status().code(), c.code) << v.status().message();
    EXPECT_NE(v.status().message().find(c.message), std::string::npos) << v.status().message();
    EXPECT_EQ(v.status().message().rfind(path + ": ", 0), 0u) << v.status().message();
  }
}

TEST(VolumeRead, IsVolumePath) {
  EXPECT_TRUE(is_volume_path("a/seg.nii"));
  EXPECT_TRUE(is_volume_path("a/SEG.NII.GZ"));
  EXPECT_TRUE(is_volume_path("knee.seg.nrrd"));
  EXPECT_TRUE(is_volume_path("v.nhdr"));
  EXPECT_FALSE(is_volume_path("bone.stl"));
  EXPECT_FALSE(is_volume_path("v.gz"));
  EXPECT_FALSE(is_volume_path(".nii"));
  auto v = read_volume("bone.stl");
  ASSERT_FALSE(v.ok());
  EXPECT_EQ(v.status().code(), ErrorCode::kUnsupported);
}

// ---- real data ------------------------------------------------------------------------------

TEST(VolumeReadRealData, TotalSegmentatorSegmentation) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  const std::string path =
      data + "/wasserth__TotalSegmentator/tests/reference_files/example_seg.nii.gz";
  if (!fs::exists(path)) GTEST_SKIP() << path << " is absent";
  LabelVolume v = read_or_fail(path);
  expect_consistent(v);
  EXPECT_EQ(v.size, (std::array<uint32_t, 3>{122, 101, 30}));
  EXPECT_EQ(v.values.size(), 42u);  // 41 labels present and the background
  size_t present = 0;
  for (const VolumeLabel& label : v.table) present += label.voxels > 0;
  EXPECT_EQ(present, 41u);
  EXPECT_EQ(v.table.size(), 117u);
  for (const char* name : {"vertebrae_T11", "rib_left_7", "costal_cartilages", "spleen"}) {
    const VolumeLabel* label = find_label(v, name);
    ASSERT_NE(label, nullptr) << name;
    EXPECT_TRUE(label->has_color) << name;
  }
  const VolumeLabel* spleen = find_label(v, "spleen");
  EXPECT_EQ(spleen->value, 1u);
  EXPECT_EQ(spleen->color, (Vec3{0, 1, 0}));
  // sform diag(3, 3, 3), origin (-177.956, 11.319, 94.3018) in RAS: LPS x = 177.956 - 3 i.
  expect_world(v, {0, 0, 0}, {177.956, -11.319, 94.3018}, 1e-3);
  expect_world(v, {121, 100, 29}, {177.956 - 363, -11.319 - 300, 94.3018 + 87}, 1e-3);
  EXPECT_TRUE(v.notes.empty()) << ::testing::PrintToString(v.notes);
}

TEST(VolumeReadRealData, TotalSegmentatorCt) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  const std::string path =
      data + "/wasserth__TotalSegmentator/tests/reference_files/example_ct.nii.gz";
  if (!fs::exists(path)) GTEST_SKIP() << path << " is absent";
  const std::string message = read_error(path);
  EXPECT_NE(message.find("an intensity volume (int32 values from"), std::string::npos) << message;
  EXPECT_NE(message.find("--threshold"), std::string::npos) << message;
  VolumeReadOptions options;
  options.threshold = 250;
  LabelVolume v = read_or_fail(path, options);
  expect_consistent(v);
  EXPECT_EQ(v.size, (std::array<uint32_t, 3>{122, 101, 112}));
  ASSERT_EQ(v.table.size(), 1u);
  EXPECT_EQ(v.table[0].name, "bone");
  EXPECT_GT(v.table[0].voxels, 1000u);
  EXPECT_LT(v.table[0].voxels, v.voxel_count() / 4);
  std::printf("example_ct.nii.gz: %s; %llu bone voxels of %zu\n", message.c_str(),
              static_cast<unsigned long long>(v.table[0].voxels), v.voxel_count());
}

}  // namespace volume_read_test
}  // namespace
}  // namespace osteon
