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
            "32b151a2894a657e0a6d27baffb847a7f6646d3c14f448c273118b9d90c34e1e");
  PackOptions bits;  // the default before the absolute one: 14 bits over each part's size
  bits.bits = 14;
  EXPECT_EQ(packed_hash({input}, bits),
            "f4b6d77c886e31e29e8ac4bf9bebd962594d99830eb6c933075f9ad926c928c3");
  PackOptions segmented;
  segmented.max_triangles = 500;
  segmented.precision = 0.05;
  segmented.chunk_bytes = 4096;
  EXPECT_EQ(packed_hash({input}, segmented),
            "d1168f44e86424e30ce30bed840e1d436047af9e21c43c219cfe4d7849a89cff");
}

TEST(GoldenOutput, PhantomStreams) {
  PhantomOptions phantom_options;
  phantom_options.detail = 2;
  Phantom phantom = make_phantom(phantom_options);
  const Mesh whole = merge_parts(std::move(phantom.scene));
  EncodeOptions bits;
  EXPECT_EQ(stream_hash(whole, bits),
            "a6e051a4af3bca6dd0155c098f2243d436c4a3aa2d53d76aaeb0307c01942c54");
  EncodeOptions precise;
  precise.precision = 0.01;
  precise.normals = true;
  EXPECT_EQ(stream_hash(whole, precise),
            "aa8483475b489baa2277be30fa97533146d2e3c8f60f46ec9676e021abc4f562");
}

TEST(GoldenOutput, BodyParts3DPackage) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  const std::string root = data + "/aHer-dev__3DAnatomy";
  PackOptions options;
  options.precision = 0.0289;
  options.names = root + "/meta.json";
  EXPECT_EQ(packed_hash({root + "/models/bones"}, options),
            "d0ccf1281a7561317845656013a3cebf33de16e6eb0748ebac123cf0b7296769");
}

TEST(GoldenOutput, MyoSimPackageWithMirroredRepeats) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  PackOptions options;
  options.precision = 0.00005;  // metres
  EXPECT_EQ(packed_hash({data + "/MyoHub__myo_sim/meshes"}, options),
            "f8bd0667cb3f8c3c09e53ccb16ed0bcbdf5e1e1fb56f3d762e4fc78c8ead3300");
  // The default, 0.05 mm, is the same bound in MyoSim's metres: one bone packs to the same bytes
  // either way (the whole set packed twice would double the test's time).
  const std::string bone = data + "/MyoHub__myo_sim/meshes/2mc.stl";
  EXPECT_EQ(packed_hash({bone}, PackOptions{}), packed_hash({bone}, options));
}

TEST(GoldenOutput, RealStreams) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  const std::pair<const char*, const char*> inputs[] = {
      {"ct-like/hip_mcs.ply", "daf30d085f11743e2650d1b3049fba3cc8e03ffd0031a4ef65c081ef34c53000"},
      {"stity__spl-abdominal-atlas/Data",
       "5b332e882e344efd4ae21689803f5a49179c245d9816c63e705a00f28984e362"}};
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
