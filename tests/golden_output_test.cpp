// SPDX-License-Identifier: Apache-2.0
// Byte-identical output across refactorings: packages and .ostm streams of fixed inputs hash to
// the values recorded when these tests were written. A change to the bytes a user gets (the codec,
// the package, the manifest) must update these hashes on purpose, and docs/FORMAT.md with them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "fixtures.hpp"
#include "osteon/codec.hpp"
#include "osteon/io.hpp"
#include "osteon/mesh.hpp"
#include "osteon/pack.hpp"
#include "support/phantom.hpp"

namespace osteon {
namespace {
namespace golden_output_test {

namespace fs = std::filesystem;
using test::read_bytes;
using test::scratch_dir;
using test::sha256_hex;
using test::write_phantom;

/// The hash of a folder: SHA-256 of `sha256sum`'s lines for every regular file, sorted by path
/// (the same as `find . -type f | sort | xargs sha256sum | sha256sum` run inside it).
std::string tree_hash(const std::string& dir) {
  std::vector<std::string> paths;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file()) paths.push_back("./" + fs::relative(entry.path(), dir).string());
  }
  std::sort(paths.begin(), paths.end());
  std::string lines;
  for (const std::string& path : paths) {
    const std::vector<uint8_t> bytes = read_bytes(dir + "/" + path.substr(2));
    lines += sha256_hex(bytes.data(), bytes.size()) + "  " + path + "\n";
  }
  return sha256_hex(lines.data(), lines.size());
}

std::string packed_hash(const std::vector<std::string>& inputs, PackOptions options) {
  options.output = scratch_dir() + "/package";
  options.threads = 2;
  Result<PackReport> result = pack(inputs, options);
  EXPECT_TRUE(result.ok()) << result.status().message();
  return result.ok() ? tree_hash(options.output) : "";
}

std::string stream_hash(const Mesh& mesh, const EncodeOptions& options) {
  Result<std::vector<uint8_t>> bytes = encode(mesh, options);
  EXPECT_TRUE(bytes.ok()) << bytes.status().message();
  return bytes.ok() ? sha256_hex(bytes.value().data(), bytes.value().size()) : "";
}

TEST(GoldenOutput, PhantomPackages) {
  const std::string input = write_phantom(2);
  PackOptions defaults;  // 0.05 mm in the parts' unit
  EXPECT_EQ(packed_hash({input}, defaults),
            "ea62bbbac81698d8e76a7edec9d508f6475dccc9f26066452adfd50c85717fc2");
  PackOptions bits;  // the default before the absolute one: 14 bits over each part's size
  bits.bits = 14;
  EXPECT_EQ(packed_hash({input}, bits),
            "8859d8c7515d3c659977b91f4fc593233f2311727f2a58d2b5e5dce41144c3bc");
  PackOptions segmented;
  segmented.max_triangles = 500;
  segmented.precision = 0.05;
  segmented.chunk_bytes = 4096;
  EXPECT_EQ(packed_hash({input}, segmented),
            "b242a184a81b7264db4c3c7baae6c7c855ea58eb3ff738f9840c4f5af5d04f99");
}

TEST(GoldenOutput, PhantomStreams) {
  PhantomOptions phantom_options;
  phantom_options.detail = 2;
  Phantom phantom = make_phantom(phantom_options);
  const Mesh whole = merge_parts(std::move(phantom.scene));
  EncodeOptions bits;
  EXPECT_EQ(stream_hash(whole, bits),
            "99ed2b11895e671f16090486d9fd17fe73c0c0886e086db0b1a23b726da2a4f4");
  EncodeOptions precise;
  precise.precision = 0.01;
  precise.normals = true;
  EXPECT_EQ(stream_hash(whole, precise),
            "006517e147c4bc5cff7519e8ece6e3fa56e2515d997ea73c31b4db2e6125f913");
}

TEST(GoldenOutput, BodyParts3DPackage) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  const std::string root = data + "/aHer-dev__3DAnatomy";
  PackOptions options;
  options.precision = 0.0289;
  options.names = root + "/meta.json";
  EXPECT_EQ(packed_hash({root + "/models/bones"}, options),
            "42d39ddb4c6880b8759a62b96ea63a972783ee4c634a36897ed33d6110618a0d");
}

TEST(GoldenOutput, MyoSimPackageWithMirroredRepeats) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  PackOptions options;
  options.precision = 0.00005;  // metres
  EXPECT_EQ(packed_hash({data + "/MyoHub__myo_sim/meshes"}, options),
            "b680afbfcfe5f4e46518905d3ccbd0b02658e71ef7a6c17c3a00de2380bee7ce");
  // The default, 0.05 mm, is the same bound in MyoSim's metres: one bone packs to the same bytes
  // either way (the whole set packed twice would double the test's time).
  const std::string bone = data + "/MyoHub__myo_sim/meshes/2mc.stl";
  EXPECT_EQ(packed_hash({bone}, PackOptions{}), packed_hash({bone}, options));
}

TEST(GoldenOutput, RealStreams) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  const std::pair<const char*, const char*> inputs[] = {
      {"ct-like/hip_mcs.ply", "28cde8bf0fcea4d8c90e77fcaf3e8e8675abefa7042554ebe2a3873c849db3c5"},
      {"stity__spl-abdominal-atlas/Data",
       "d2f99f5ac17fb77446abfdd4fdb3259dd1d8674d82888d8a5cc06bba806f6bb5"}};
  for (const auto& [name, expected] : inputs) {
    Result<Scene> scene = read_path(data + "/" + name);
    ASSERT_TRUE(scene.ok()) << scene.status().message();
    const Mesh mesh = merge_parts(std::move(scene.value()));
    EXPECT_EQ(stream_hash(mesh, EncodeOptions{}), expected) << name;
  }
}

}  // namespace golden_output_test
}  // namespace
}  // namespace osteon
