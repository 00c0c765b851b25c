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
            "f771ab07df68f8ad940c27dbb5afafc3d7edd53cbd4536bab6bb3b20025dabc7");
  PackOptions bits;  // the default before the absolute one: 14 bits over each part's size
  bits.bits = 14;
  EXPECT_EQ(packed_hash({input}, bits),
            "524a4197e73cfa3f984c0e12b9c086a1ed45a214c38af97b517a841536cf05e3");
  PackOptions segmented;
  segmented.max_triangles = 500;
  segmented.precision = 0.05;
  segmented.chunk_bytes = 4096;
  EXPECT_EQ(packed_hash({input}, segmented),
            "46edc2b812c8e3980eefb903d4852cdf82d7fb13b06fdef01b2b89dc3f253559");
}

TEST(GoldenOutput, PhantomStreams) {
  PhantomOptions phantom_options;
  phantom_options.detail = 2;
  Phantom phantom = make_phantom(phantom_options);
  const Mesh whole = merge_parts(std::move(phantom.scene));
  EncodeOptions bits;
  EXPECT_EQ(stream_hash(whole, bits),
            "2be9a9eba4cb25f98052e983db8a6256d1da2efcb2e09ca8bde08514f869d30e");
  EncodeOptions precise;
  precise.precision = 0.01;
  precise.normals = true;
  EXPECT_EQ(stream_hash(whole, precise),
            "47a11b5eb28be4963b7a357746186d27fbdb5e095dc2fa085c0ce45f0a1a831e");
}

TEST(GoldenOutput, BodyParts3DPackage) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  const std::string root = data + "/aHer-dev__3DAnatomy";
  PackOptions options;
  options.precision = 0.0289;
  options.names = root + "/meta.json";
  EXPECT_EQ(packed_hash({root + "/models/bones"}, options),
            "4a0900dbf08619438138e7c51b005373bd0145b7c64baf7f0ae4e5286e6844d7");
}

TEST(GoldenOutput, MyoSimPackageWithMirroredRepeats) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  PackOptions options;
  options.precision = 0.00005;  // metres
  EXPECT_EQ(packed_hash({data + "/MyoHub__myo_sim/meshes"}, options),
            "39647bd38c261464c4f3fc2225092b19e78257b56ab4e36e97de0d9ec755c86d");
  // The default, 0.05 mm, is the same bound in MyoSim's metres: one bone packs to the same bytes
  // either way (the whole set packed twice would double the test's time).
  const std::string bone = data + "/MyoHub__myo_sim/meshes/2mc.stl";
  EXPECT_EQ(packed_hash({bone}, PackOptions{}), packed_hash({bone}, options));
}

TEST(GoldenOutput, RealStreams) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  const std::pair<const char*, const char*> inputs[] = {
      {"ct-like/hip_mcs.ply", "dad7767ac09de575fff8ce26809d67f1287ea40655d0a8bdbb50e14c553535e0"},
      {"stity__spl-abdominal-atlas/Data",
       "373c0719cd34122cf6dcc59ee6edf03721ae5fd520d8e4d0fd8963972a572828"}};
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
