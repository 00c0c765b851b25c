// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "../fuzz/manifest_fuzz_check.hpp"
#include "../fuzz/names_fuzz_check.hpp"
#include "../fuzz/regions_fuzz_check.hpp"
#include "../fuzz/seg_fuzz_check.hpp"
#include "../fuzz/volume_fuzz_input.hpp"
#include "fixtures.hpp"
#include "osteon/diagnose.hpp"
#include "osteon/io.hpp"
#include "osteon/volume.hpp"

// Replays every file of the fuzzers' corpus (fuzz/corpus/<format>/: hand-made seeds, minimized
// interesting inputs and crash- reproducers) through the reader the fuzzer for that folder uses,
// then welds and diagnoses what it returns, exactly as fuzz/read_fuzzer.cpp does; the label-volume
// corpus (nii, niigz, nrrd, nhdr) goes through read_volume as fuzz/volume_fuzzer.cpp does, the
// manifest corpus through parse_manifest and write_manifest as fuzz/manifest_fuzzer.cpp does, the
// .seg corpus through parse_seg and the evaluator as fuzz/seg_fuzzer.cpp does, the names files
// and ontology tables through parse_names and place_by_fma_tables as fuzz/names_fuzzer.cpp and
// fuzz/regions_fuzzer.cpp do. Under ASan+UBSan this keeps every past fuzzer finding fixed.

namespace osteon {
namespace {
namespace fuzz_corpus_test {

namespace fs = std::filesystem;

const std::vector<std::string>& corpus_formats() {
  static const std::vector<std::string> formats = {"stl", "obj",  "ply", "off",
                                                   "vtk", "gltf", "glb"};
  return formats;
}

std::string corpus_dir() {
  return std::string(OSTEON_SOURCE_DIR) + "/fuzz/corpus";
}

std::vector<fs::path> corpus_files(const std::string& format) {
  std::vector<fs::path> files;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(corpus_dir() + "/" + format, ec)) {
    if (entry.is_regular_file()) files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

/// The name the fuzzer would give these bytes: the extension picks the reader, as in the fuzzer.
std::string source_name(const std::string& format, const fs::path& file) {
  std::string name = format + "/" + file.filename().string();
  if (file.extension() != "." + format) name += "." + format;
  return name;
}

class FuzzCorpus : public ::testing::TestWithParam<std::string> {};

TEST_P(FuzzCorpus, EveryInputParsesOrFailsCleanly) {
  const std::string& format = GetParam();
  std::vector<fs::path> files = corpus_files(format);
  ASSERT_FALSE(files.empty()) << "no seeds in " << corpus_dir() << "/" << format;
  size_t parsed = 0;
  for (const fs::path& file : files) {
    std::string source = source_name(format, file);
    SCOPED_TRACE(source);
    std::vector<uint8_t> bytes = test::read_bytes(file.string());
    ASSERT_LT(bytes.size(), 4096u) << "corpus files stay small";
    auto scene = read_memory(bytes.data(), bytes.size(), source, Format::kUnknown);
    if (!scene.ok()) {
      const std::string& message = scene.status().message();
      EXPECT_NE(scene.status().code(), ErrorCode::kOk);
      EXPECT_EQ(message.rfind(source + ": ", 0), 0u) << message;
      EXPECT_GT(message.size(), source.size() + 2) << message;
      continue;
    }
    ++parsed;
    ASSERT_FALSE(scene->parts.empty());
    for (Mesh& part : scene->parts) {
      ASSERT_EQ(part.indices.size() % 3, 0u);
      for (uint32_t index : part.indices) ASSERT_LT(index, part.positions.size());
      ASSERT_TRUE(part.normals.empty() || part.normals.size() == part.positions.size());
      DiagnosisReport report = diagnose(part);
      EXPECT_EQ(report.triangles, part.triangle_count());
      weld(part, WeldOptions{1e-3f});
      for (uint32_t index : part.indices) ASSERT_LT(index, part.positions.size());
    }
  }
  // The hand-made seeds are valid files: at least some of each format must parse.
  EXPECT_GT(parsed, 0u) << "not one input of " << format << " parses";
}

INSTANTIATE_TEST_SUITE_P(Formats, FuzzCorpus, ::testing::ValuesIn(corpus_formats()),
                         [](const auto& param_info) { return param_info.param; });

TEST(FuzzCorpusFiles, StaySmall) {
  for (const std::string& format : corpus_formats()) {
    std::vector<fs::path> files = corpus_files(format);
    EXPECT_LE(files.size(), 40u) << format;
    for (const fs::path& file : files) EXPECT_LT(fs::file_size(file), 4096u) << file;
  }
}

// ---- the label-volume readers (fuzz/volume_fuzzer.cpp) ---------------------------------------

const std::vector<std::string>& volume_corpus_formats() {
  static const std::vector<std::string> formats = {"nii", "niigz", "nrrd", "nhdr"};
  return formats;
}

class VolumeFuzzCorpus : public ::testing::TestWithParam<std::string> {};

// Each input is written and read as the fuzzer does (fuzz/volume_fuzz_input.hpp), with the
// fuzzer's options: a 64 MiB label limit, and a threshold for inputs of odd size.
TEST_P(VolumeFuzzCorpus, EveryInputReadsOrFailsCleanly) {
  const std::string& format = GetParam();
  std::vector<fs::path> files = corpus_files(format);
  ASSERT_FALSE(files.empty()) << "no seeds in " << corpus_dir() << "/" << format;
  const std::string dir = test::scratch_dir();
  size_t parsed = 0;
  for (const fs::path& file : files) {
    SCOPED_TRACE(file.filename().string());
    std::vector<uint8_t> bytes = test::read_bytes(file.string());
    ASSERT_LT(bytes.size(), 4096u) << "corpus files stay small";
    const std::string path = fuzz::write_volume_input(dir, format, bytes.data(), bytes.size());
    ASSERT_FALSE(path.empty());
    VolumeReadOptions options;
    options.max_voxel_bytes = uint64_t{64} << 20;
    if (bytes.size() % 2 == 1) options.threshold = 100;
    auto volume = read_volume(path, options);
    if (!volume.ok()) {
      const std::string& message = volume.status().message();
      EXPECT_NE(volume.status().code(), ErrorCode::kOk);
      EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
      EXPECT_GT(message.size(), path.size() + 2) << message;
      continue;
    }
    ++parsed;
    EXPECT_EQ(fuzz::volume_contract_broken(*volume), "");
  }
  EXPECT_GT(parsed, 0u) << "not one input of " << format << " reads";
}

INSTANTIATE_TEST_SUITE_P(Formats, VolumeFuzzCorpus, ::testing::ValuesIn(volume_corpus_formats()),
                         [](const auto& param_info) { return param_info.param; });

TEST(VolumeFuzzCorpusFiles, StaySmall) {
  for (const std::string& format : volume_corpus_formats()) {
    std::vector<fs::path> files = corpus_files(format);
    EXPECT_LE(files.size(), 40u) << format;
    for (const fs::path& file : files) EXPECT_LT(fs::file_size(file), 4096u) << file;
  }
}

// ---- the manifest, .seg, names and ontology-table readers (fuzz/<name>_fuzzer.cpp) -----------

/// Replays corpus/<format>/ through `one` (the fuzzer's own checks): no input may break a promise,
/// and some of the seeds (valid files) must parse.
template <typename Outcome>
void replay_text_corpus(const std::string& format,
                        Outcome (*one)(const uint8_t*, size_t, const std::string&)) {
  std::vector<fs::path> files = corpus_files(format);
  ASSERT_FALSE(files.empty()) << "no seeds in " << corpus_dir() << "/" << format;
  EXPECT_LE(files.size(), 40u) << format;
  size_t parsed = 0;
  for (const fs::path& file : files) {
    const std::string source = format + "/" + file.filename().string();
    SCOPED_TRACE(source);
    std::vector<uint8_t> bytes = test::read_bytes(file.string());
    ASSERT_LT(bytes.size(), 4096u) << "corpus files stay small";
    const Outcome outcome = one(bytes.data(), bytes.size(), source);
    EXPECT_EQ(outcome.broken, "");
    if (outcome.parsed) ++parsed;
  }
  EXPECT_GT(parsed, 0u) << "not one input of " << format << " parses";
}

TEST(ManifestFuzzCorpus, EveryInputParsesOrFailsCleanly) {
  replay_text_corpus("manifest", &fuzz::manifest_fuzz_one);
}

TEST(SegFuzzCorpus, EveryInputParsesOrFailsCleanly) {
  replay_text_corpus("seg", &fuzz::seg_fuzz_one);
}

TEST(NamesFuzzCorpus, EveryInputParsesOrFailsCleanly) {
  replay_text_corpus("names", &fuzz::names_fuzz_one);
}

// The source ("regions/<file>") is the tables' folder in the messages.
TEST(RegionsFuzzCorpus, EveryInputPlacesOrFailsCleanly) {
  replay_text_corpus("regions", &fuzz::regions_fuzz_one);
}

}  // namespace fuzz_corpus_test
}  // namespace
}  // namespace osteon
