// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "osteon/io.hpp"
#include "osteon/mesh.hpp"

// Shared test helpers: where the real data is, scratch folders, and the mesh categories each
// algorithm's tests loop over (STYLE habit 9).

namespace osteon::test {

/// ../shared/data beside the checkout, or "" when it is absent (tests then skip and say so).
std::string shared_data_dir();
/// Skips the current test with a message when ../shared/data is absent; returns the folder.
#define OSTEON_REQUIRE_SHARED_DATA(var)                                                     \
  std::string var = ::osteon::test::shared_data_dir();                                      \
  if (var.empty()) GTEST_SKIP() << "../shared/data is absent: real-mesh test skipped; "     \
                                   "the generated meshes cover this case";

/// A fresh, empty folder under the system temp dir, unique to this test.
std::string scratch_dir();
std::vector<uint8_t> read_bytes(const std::string& path);
void write_bytes(const std::string& path, const std::string& bytes);
/// read_memory on a string; fails the test (ADD_FAILURE) and returns an empty scene on error.
Scene parse_or_fail(const std::string& bytes, const std::string& source,
                    const ReadOptions& options = {});
/// The error message read_memory gives for these bytes ("" when it succeeds).
std::string parse_error(const std::string& bytes, const std::string& source);

/// Lower-case hex SHA-256 (OpenSSL's one-shot SHA256, independent of pack's EVP code).
std::string sha256_hex(const void* data, size_t size);
inline std::string sha256_hex(const std::vector<uint8_t>& bytes) {
  return sha256_hex(bytes.data(), bytes.size());
}

/// The generated phantom skeleton (PhantomOptions::detail) written as one PLY per part into a
/// fresh folder; returns the folder.
std::string write_phantom(int detail = 2);

/// What the osteon CLI (the real binary, OSTEON_CLI_PATH) did with some arguments.
struct CliRun {
  int status = -1;
  std::string out;  ///< stdout
  std::string err;  ///< stderr
};
/// Runs `osteon <args>` through the shell (args are pasted in as they are).
CliRun run_cli(const std::string& args);

struct NamedMesh {
  std::string category;  ///< "closed", "open", "genus1", "nonmanifold", "multicomponent", "degenerate"
  Mesh mesh;
};
/// One or more small meshes of each category.
std::vector<NamedMesh> mesh_categories();

/// The triangles of a mesh as position triples, sorted (and each rotated to start at its smallest
/// corner, keeping orientation): equal for two meshes that hold the same oriented triangles
/// whatever their vertex order.
std::vector<std::array<float, 9>> canonical_triangles(const Mesh& mesh);

}  // namespace osteon::test
