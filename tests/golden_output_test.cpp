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
            "f6d4ec2321ef85da1d734e727b2950fd0512f7e4754bfcb93ef2c7147e7b931f");
  PackOptions bits;  // the default before the absolute one: 14 bits over each part's size
  bits.bits = 14;
  EXPECT_EQ(packed_hash({input}, bits),
            "d46dd5b0653832060033b51dd59816f059932152d45ccf1c316cae2c3da94926");
  PackOptions segmented;
  segmented.max_triangles = 500;
  segmented.precision = 0.05;
  segmented.chunk_bytes = 4096;
  EXPECT_EQ(packed_hash({input}, segmented),
            "d871590bb23ccc913eba0a75ec8d1e64a8a34fce760b03542193c817c52f52f5");
}

TEST(GoldenOutput, PhantomStreams) {
  PhantomOptions phantom_options;
  phantom_options.detail = 2;
  Phantom phantom = make_phantom(phantom_options);
  const Mesh whole = merge_parts(std::move(phantom.scene));
  EncodeOptions bits;
  EXPECT_EQ(stream_hash(whole, bits),
            "3e74d941b7958fe98bbfbabad48fbd9b04252e4cb9d5c5851addbfe17d75a397");
  EncodeOptions precise;
  precise.precision = 0.01;
  precise.normals = true;
  EXPECT_EQ(stream_hash(whole, precise),
            "51eecf51ac55a1c490bcb8f5c7a8b867b71b5b9d4030ea2b51b863c6f2f2f489");
}

TEST(GoldenOutput, BodyParts3DPackage) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  const std::string root = data + "/aHer-dev__3DAnatomy";
  PackOptions options;
  options.precision = 0.0289;
  options.names = root + "/meta.json";
  EXPECT_EQ(packed_hash({root + "/models/bones"}, options),
            "c6b23ecf923fcc3d45119d54b07c65a115182c82ea42526ca6a5a130a7525743");
}

TEST(GoldenOutput, MyoSimPackageWithMirroredRepeats) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  PackOptions options;
  options.precision = 0.00005;  // metres
  EXPECT_EQ(packed_hash({data + "/MyoHub__myo_sim/meshes"}, options),
            "f598e38a03a80a5502459d28177e789b9f30843f91721fd7a3aeca7e7df6382b");
  // The default, 0.05 mm, is the same bound in MyoSim's metres: one bone packs to the same bytes
  // either way (the whole set packed twice would double the test's time).
  const std::string bone = data + "/MyoHub__myo_sim/meshes/2mc.stl";
  EXPECT_EQ(packed_hash({bone}, PackOptions{}), packed_hash({bone}, options));
}

TEST(GoldenOutput, RealStreams) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  const std::pair<const char*, const char*> inputs[] = {
      {"ct-like/hip_mcs.ply", "4070bcf41bef0e0d28abc333e96cf70ab4552139c2ec7a5407130d28de1afbfb"},
      {"stity__spl-abdominal-atlas/Data",
       "90d70400b6314fd9e7d95326e87ff97859810c47040ff9c06a4ba6f8c9d73984"}};
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
