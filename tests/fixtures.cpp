// SPDX-License-Identifier: Apache-2.0
#include "fixtures.hpp"

#include <gtest/gtest.h>
#include <openssl/sha.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <mutex>
#include <string>
#include <vector>

#include "support/phantom.hpp"

namespace fs = std::filesystem;

namespace osteon::test {

std::string shared_data_dir() {
  const char* env = std::getenv("OSTEON_SHARED_DATA");
  std::string dir = env ? env : OSTEON_SHARED_DATA_DIR;
  std::error_code ec;
  return fs::is_directory(dir, ec) ? dir : std::string();
}

namespace {

// The scratch folders of the running test, removed when it passes (a failing test's stay, to be
// looked at). Registered with GoogleTest before main runs.
std::mutex scratch_mutex;
std::vector<fs::path> scratch_dirs;

class ScratchCleaner : public ::testing::EmptyTestEventListener {
  void OnTestEnd(const ::testing::TestInfo& info) override {
    std::lock_guard<std::mutex> lock(scratch_mutex);
    if (info.result() != nullptr && info.result()->Passed()) {
      std::error_code ec;
      for (const fs::path& dir : scratch_dirs) fs::remove_all(dir, ec);
    }
    scratch_dirs.clear();
  }
};

[[maybe_unused]] const bool scratch_cleaner_registered = [] {
  ::testing::UnitTest::GetInstance()->listeners().Append(new ScratchCleaner);
  return true;
}();

}  // namespace

std::string scratch_dir() {
  static std::atomic<int> counter{0};
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = info ? std::string(info->test_suite_name()) + "." + info->name() : "test";
  std::replace(name.begin(), name.end(), '/', '_');
  fs::path dir = fs::temp_directory_path() / ("osteon_test_" + std::to_string(::getpid()) + "_" +
                                              std::to_string(counter++) + "_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  {
    std::lock_guard<std::mutex> lock(scratch_mutex);
    scratch_dirs.push_back(dir);
  }
  return dir.string();
}

std::vector<uint8_t> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return {};
  std::vector<uint8_t> bytes(static_cast<size_t>(in.tellg()));
  in.seekg(0);
  in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  return bytes;
}

void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

Scene parse_or_fail(const std::string& bytes, const std::string& source,
                    const ReadOptions& options) {
  auto result = read_memory(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), source,
                            Format::kUnknown, options);
  if (!result.ok()) {
    ADD_FAILURE() << "read_memory(" << source << ") failed: " << result.status().message();
    return {};
  }
  return std::move(result).value();
}

std::string parse_error(const std::string& bytes, const std::string& source) {
  auto result = read_memory(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), source);
  return result.ok() ? std::string() : result.status().message();
}

std::vector<NamedMesh> mesh_categories() {
  std::vector<NamedMesh> out;
  out.push_back({"closed", make_icosphere(2, 1.0f)});
  out.push_back({"closed", make_box({0, 0, 0}, {1, 2, 3})});
  out.push_back({"open", make_open_cylinder(1.0f, 2.0f, 16, 4)});
  out.push_back({"genus1", make_torus(2.0f, 0.5f, 24, 12)});
  out.push_back({"nonmanifold", make_nonmanifold_book()});
  out.push_back({"nonmanifold", make_bowtie_tetrahedra()});
  {
    Mesh a = make_icosphere(1, 1.0f);
    Mesh b = make_box({3, 3, 3}, {4, 4, 4});
    uint32_t base = static_cast<uint32_t>(a.positions.size());
    a.positions.insert(a.positions.end(), b.positions.begin(), b.positions.end());
    for (uint32_t i : b.indices) a.indices.push_back(base + i);
    out.push_back({"multicomponent", std::move(a)});
  }
  {
    Mesh m = make_box({0, 0, 0}, {1, 1, 1});
    m.indices.insert(m.indices.end(), {0, 0, 1});  // repeated index
    m.positions.push_back({0.5f, 0, 0});           // on the edge 0-1 of the box (x axis)
    uint32_t mid = static_cast<uint32_t>(m.positions.size() - 1);
    m.indices.insert(m.indices.end(), {0, mid, 1});  // zero area, if 0 and 1 lie on the x axis
    out.push_back({"degenerate", std::move(m)});
  }
  return out;
}

std::vector<std::array<float, 9>> canonical_triangles(const Mesh& mesh) {
  std::vector<std::array<float, 9>> tris;
  tris.reserve(mesh.triangle_count());
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    std::array<Vec3, 3> c;
    for (int k = 0; k < 3; ++k) c[k] = mesh.positions[mesh.indices[3 * t + k]];
    auto less = [](const Vec3& a, const Vec3& b) {
      return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z);
    };
    int first = 0;
    for (int k = 1; k < 3; ++k)
      if (less(c[k], c[first])) first = k;
    std::array<float, 9> row;
    for (int k = 0; k < 3; ++k) {
      const Vec3& p = c[(first + k) % 3];
      row[3 * k] = p.x;
      row[3 * k + 1] = p.y;
      row[3 * k + 2] = p.z;
    }
    tris.push_back(row);
  }
  std::sort(tris.begin(), tris.end());
  return tris;
}

CliRun run_cli(const std::string& args) {
  const std::string err_path = scratch_dir() + "/stderr.txt";
  const std::string command = std::string(OSTEON_CLI_PATH) + " " + args + " 2>" + err_path;
  CliRun run;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return run;
  char buffer[4096];
  size_t n;
  while ((n = fread(buffer, 1, sizeof(buffer), pipe)) > 0) run.out.append(buffer, n);
  const int raw = pclose(pipe);
  run.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  const auto bytes = read_bytes(err_path);
  run.err.assign(bytes.begin(), bytes.end());
  return run;
}

std::string sha256_hex(const void* data, size_t size) {
  unsigned char digest[SHA256_DIGEST_LENGTH];
  SHA256(static_cast<const unsigned char*>(data), size, digest);
  char hex[2 * SHA256_DIGEST_LENGTH + 1];
  for (int i = 0; i < SHA256_DIGEST_LENGTH; ++i) std::snprintf(hex + 2 * i, 3, "%02x", digest[i]);
  return hex;
}

std::string write_phantom(int detail) {
  PhantomOptions options;
  options.detail = detail;
  const Phantom phantom = make_phantom(options);
  const std::string dir = scratch_dir() + "/phantom";
  std::filesystem::create_directories(dir);
  for (const Mesh& part : phantom.scene.parts) {
    EXPECT_TRUE(write_mesh(dir + "/" + part.name + ".ply", part).ok()) << part.name;
  }
  return dir;
}

}  // namespace osteon::test
