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
            "7612c28b14ed2de1ebeb8db26395af9cd4092f2e9bff9ab73e4f2ecb145c4691");
  PackOptions bits;  // the default before the absolute one: 14 bits over each part's size
  bits.bits = 14;
  EXPECT_EQ(packed_hash({input}, bits),
            "d8500209d235ca6221b9fa2e7fa5bde3573dbedddce4f59d29c0fd09a438b184");
  PackOptions segmented;
  segmented.max_triangles = 500;
  segmented.precision = 0.05;
  segmented.chunk_bytes = 4096;
  EXPECT_EQ(packed_hash({input}, segmented),
            "e9aa5c20a36e25dfda78eea0adce38cd938044095505d7bdd8608d42ed0a7323");
}

TEST(GoldenOutput, PhantomStreams) {
  PhantomOptions phantom_options;
  phantom_options.detail = 2;
  Phantom phantom = make_phantom(phantom_options);
  const Mesh whole = merge_parts(std::move(phantom.scene));
  EncodeOptions bits;
  EXPECT_EQ(stream_hash(whole, bits),
            "4d9840195539a944bf6bfc1b88c1a2e0192a91653cbe942b9e053de4fe32ec99");
  EncodeOptions precise;
  precise.precision = 0.01;
  precise.normals = true;
  EXPECT_EQ(stream_hash(whole, precise),
            "6ec6ee3b2f1298be4636a75783e708ee5d202f9ba98841fa38cd91b17b3d7918");
}

TEST(GoldenOutput, BodyParts3DPackage) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  const std::string root = data + "/aHer-dev__3DAnatomy";
  PackOptions options;
  options.precision = 0.0289;
  options.names = root + "/meta.json";
  EXPECT_EQ(packed_hash({root + "/models/bones"}, options),
            "620e4fa97e661117c4a57d784063ad5298dd873f2d99001d437bc8e40913d129");
}

TEST(GoldenOutput, MyoSimPackageWithMirroredRepeats) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  PackOptions options;
  options.precision = 0.00005;  // metres
  EXPECT_EQ(packed_hash({data + "/MyoHub__myo_sim/meshes"}, options),
            "13cbab5e1c8fa5c6147b74c5e39aec4fcc2aefcf554eaae2e5ee3cb46df28587");
  // The default, 0.05 mm, is the same bound in MyoSim's metres: one bone packs to the same bytes
  // either way (the whole set packed twice would double the test's time).
  const std::string bone = data + "/MyoHub__myo_sim/meshes/2mc.stl";
  EXPECT_EQ(packed_hash({bone}, PackOptions{}), packed_hash({bone}, options));
}

TEST(GoldenOutput, RealStreams) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  const std::pair<const char*, const char*> inputs[] = {
      {"ct-like/hip_mcs.ply", "0bf0f8149d62411d671adb6b365804435760338b681520c2c712f0561d7b002c"},
      {"stity__spl-abdominal-atlas/Data",
       "10665712bf656662a2f2b59f9503cf71e76c6ef92fcc052605618d057dd6e696"}};
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
