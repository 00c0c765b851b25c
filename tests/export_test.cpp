// SPDX-License-Identifier: Apache-2.0
#include "osteon/export.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <unordered_map>
#include <vector>

#include "fixtures.hpp"
#include "osteon/io.hpp"
#include "osteon/pack.hpp"
#include "osteon/package.hpp"

namespace osteon {
namespace {
namespace export_test {

namespace fs = std::filesystem;
using nlohmann::json;
using test::read_bytes;
using test::run_cli;
using test::scratch_dir;
using test::write_phantom;

/// The phantom (mirrored, rotated and exact copies), packed in memory with small components so
/// that parts have several primitives.
PackageData phantom_package() {
  PackOptions options;
  options.max_triangles = 1500;
  options.levels = 1;
  options.threads = 2;
  Result<PackageData> package = pack_in_memory({write_phantom()}, options);
  EXPECT_TRUE(package.ok()) << package.status().message();
  return package.ok() ? std::move(package).value() : PackageData();
}

/// A multi-part file's parts are "<file stem>/<name>"; the name alone.
std::string part_name(const std::string& name) {
  const size_t slash = name.find('/');
  return slash == std::string::npos ? name : name.substr(slash + 1);
}

/// The JSON chunk of a GLB, or the .gltf's text.
json document(const std::string& path) {
  const std::vector<uint8_t> bytes = read_bytes(path);
  if (bytes.size() >= 20 && std::memcmp(bytes.data(), "glTF", 4) == 0) {
    uint32_t length = 0;
    std::memcpy(&length, bytes.data() + 12, 4);
    return json::parse(bytes.begin() + 20, bytes.begin() + 20 + length);
  }
  return json::parse(bytes.begin(), bytes.end());
}

double signed_volume(const Mesh& mesh) {
  double volume = 0;
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    const Vec3d a = to_double(mesh.positions[mesh.indices[3 * t]]);
    const Vec3d b = to_double(mesh.positions[mesh.indices[3 * t + 1]]);
    const Vec3d c = to_double(mesh.positions[mesh.indices[3 * t + 2]]);
    volume += dot(a, cross(b, c)) / 6;
  }
  return volume;
}

/// Checks a read-back part against the package's: every vertex within `bound` of a package
/// vertex, and the same oriented triangles on those vertices (exact connectivity and winding).
void expect_same_part(const Mesh& exported, const Mesh& packaged, double bound) {
  ASSERT_EQ(exported.triangle_count(), packaged.triangle_count());
  // Package vertices by position (equal positions are one vertex), in a hash grid.
  constexpr double kCell = 1.0;
  auto cell_of = [&](const Vec3& p) {
    return std::array<int64_t, 3>{int64_t(std::floor(p.x / kCell)),
                                  int64_t(std::floor(p.y / kCell)),
                                  int64_t(std::floor(p.z / kCell))};
  };
  std::map<std::array<int64_t, 3>, std::vector<uint32_t>> grid;
  for (uint32_t v = 0; v < packaged.positions.size(); ++v) {
    grid[cell_of(packaged.positions[v])].push_back(v);
  }
  std::map<std::array<float, 3>, uint32_t> id_of_position;
  std::vector<uint32_t> id(packaged.positions.size());
  for (uint32_t v = 0; v < packaged.positions.size(); ++v) {
    const Vec3& p = packaged.positions[v];
    id[v] = id_of_position.emplace(std::array<float, 3>{p.x, p.y, p.z}, id_of_position.size())
                .first->second;
  }
  double worst = 0;
  std::vector<uint32_t> match(exported.positions.size());
  for (size_t v = 0; v < exported.positions.size(); ++v) {
    const Vec3& p = exported.positions[v];
    const auto c = cell_of(p);
    double best = INFINITY;
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          auto it = grid.find({c[0] + dx, c[1] + dy, c[2] + dz});
          if (it == grid.end()) continue;
          for (uint32_t u : it->second) {
            const double d = length(to_double(p) - to_double(packaged.positions[u]));
            if (d < best) best = d, match[v] = id[u];
          }
        }
      }
    }
    worst = std::max(worst, best);
  }
  EXPECT_LE(worst, bound) << exported.name;
  auto canonical = [](uint32_t a, uint32_t b, uint32_t c) {
    if (b < a && b < c) return std::array<uint32_t, 3>{b, c, a};
    if (c < a && c < b) return std::array<uint32_t, 3>{c, a, b};
    return std::array<uint32_t, 3>{a, b, c};
  };
  std::vector<std::array<uint32_t, 3>> mine, theirs;
  for (size_t t = 0; t < exported.triangle_count(); ++t) {
    mine.push_back(canonical(match[exported.indices[3 * t]], match[exported.indices[3 * t + 1]],
                             match[exported.indices[3 * t + 2]]));
    theirs.push_back(canonical(id[packaged.indices[3 * t]], id[packaged.indices[3 * t + 1]],
                               id[packaged.indices[3 * t + 2]]));
  }
  std::sort(mine.begin(), mine.end());
  std::sort(theirs.begin(), theirs.end());
  EXPECT_TRUE(mine == theirs) << exported.name << ": other triangles or windings";
}

/// What read_package draws for `package` (the reference), by part name.
std::map<std::string, Mesh> drawn_parts(const PackageData& package, const std::string& dir) {
  // Write the package to disk the way pack does, then read it back through read_package.
  fs::create_directories(dir + "/c");
  for (size_t k = 0; k < package.chunks.size(); ++k) {
    EXPECT_TRUE(write_file_atomic(dir + "/" + package.manifest.chunks[k].file,
                                  package.chunks[k].data(), package.chunks[k].size())
                    .ok());
  }
  const std::string text = write_manifest(package.manifest);
  EXPECT_TRUE(write_file_atomic(dir + "/manifest.json", text.data(), text.size()).ok());
  Result<Scene> scene = read_package(dir);
  EXPECT_TRUE(scene.ok()) << scene.status().message();
  std::map<std::string, Mesh> parts;
  if (!scene.ok()) return parts;
  for (Mesh& mesh : scene.value().parts) parts[mesh.name] = std::move(mesh);
  return parts;
}

/// Reads `path` back with the library's reader (no welding) and checks every part.
void expect_reads_back(const std::string& path, const PackageData& package,
                       const std::map<std::string, Mesh>& reference, const ExportReport& report) {
  ReadOptions options;
  options.weld = false;
  Result<Scene> scene = read_path(path, options);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  ASSERT_EQ(scene->parts.size(), package.manifest.parts.size());
  std::map<std::string, const Mesh*> by_name;
  for (const Mesh& mesh : scene->parts) by_name[part_name(mesh.name)] = &mesh;
  ASSERT_EQ(by_name.size(), package.manifest.parts.size()) << "part names are not unique";
  EXPECT_GT(report.error_bound, 0);
  EXPECT_LE(report.max_deviation, report.error_bound);
  for (const ManifestPart& part : package.manifest.parts) {
    SCOPED_TRACE(part.name);
    ASSERT_TRUE(by_name.count(part.name)) << "missing part";
    const Mesh& exported = *by_name[part.name];
    const Mesh& packaged = reference.at(part.name);
    // Within float rounding of the package's vertices (the export's measured deviation plus the
    // reader's rounding to float), far inside the package's bound.
    expect_same_part(exported, packaged, report.max_deviation + 1.5e-4);
    EXPECT_LT(report.max_deviation + 1.5e-4, report.error_bound);
    // Mirrored instances keep their outward winding: the signed volume keeps its sign.
    const double a = signed_volume(exported), b = signed_volume(packaged);
    if (std::abs(b) > 1) {
      EXPECT_EQ(a > 0, b > 0) << a << " vs " << b;
    }
  }
}

TEST(Export, PhantomReadsBackCompressedAndPlain) {
  const PackageData package = phantom_package();
  ASSERT_FALSE(package.manifest.parts.empty());
  const std::string dir = scratch_dir();
  const auto reference = drawn_parts(package, dir + "/package");
  size_t mirrored_in_package = 0;
  for (const ManifestInstance& i : package.manifest.instances) mirrored_in_package += i.mirror;
  ASSERT_GT(mirrored_in_package, 0u) << "the phantom has mirrored copies";

  struct Case {
    const char* file;
    ExportOptions options;
  };
  const Case cases[] = {
      {"compressed.glb", {}},
      {"plain.glb", {.compress = false}},
      {"float.glb", {.compress = false, .quantize = false}},
      {"compressed.gltf", {}},
      {"no_instancing.glb", {.instancing = false}},
  };
  uint64_t compressed_bytes = 0, plain_bytes = 0;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.file);
    const std::string path = dir + "/" + c.file;
    ExportReport report;
    const Status status = export_gltf(package, path, c.options, &report);
    ASSERT_TRUE(status.ok()) << status.message();
    expect_reads_back(path, package, reference, report);
    EXPECT_EQ(report.parts, package.manifest.parts.size());
    uint64_t drawn = 0;
    for (const auto& [name, mesh] : reference) drawn += mesh.triangle_count();
    EXPECT_EQ(report.triangles, drawn);

    const json doc = document(path);
    const json required = doc.value("extensionsRequired", json::array());
    auto requires_ext = [&](const char* name) {
      return std::find(required.begin(), required.end(), name) != required.end();
    };
    EXPECT_EQ(requires_ext("EXT_meshopt_compression"), c.options.compress);
    EXPECT_EQ(requires_ext("EXT_mesh_gpu_instancing"), c.options.instancing);
    EXPECT_TRUE(requires_ext("KHR_mesh_quantization"));  // int8 normals at least
    size_t instancing = 0, mirror_nodes = 0, listed = 0;
    for (const json& node : doc["nodes"]) {
      if (node.contains("extensions") && node["extensions"].contains("EXT_mesh_gpu_instancing")) {
        ++instancing;
        const json& attributes = node["extensions"]["EXT_mesh_gpu_instancing"]["attributes"];
        const size_t count = doc["accessors"][attributes["TRANSLATION"].get<size_t>()]["count"];
        ASSERT_EQ(node["extras"]["osteon"]["instances"].size(), count);
        listed += count;
        if (node.value("scale", json::array({1, 1, 1}))[0].get<double>() < 0) ++mirror_nodes;
      }
    }
    if (c.options.instancing) {
      EXPECT_GT(instancing, 0u);
      EXPECT_GT(mirror_nodes, 0u);
      EXPECT_EQ(listed, report.instances);
      EXPECT_GT(report.mirrored_instances, 0u);
    } else {
      EXPECT_EQ(instancing, 0u);
      EXPECT_EQ(report.part_nodes, package.manifest.parts.size());
    }
    if (c.options.quantize) {
      EXPECT_EQ(report.float_meshes, 0u);
    }
    if (std::string(c.file) == "compressed.glb") compressed_bytes = report.bytes;
    if (std::string(c.file) == "plain.glb") plain_bytes = report.bytes;
    if (std::string(c.file) == "compressed.gltf") {
      EXPECT_TRUE(fs::exists(dir + "/compressed.bin"));
    }
  }
  EXPECT_LT(compressed_bytes * 2, plain_bytes);
}

TEST(Export, PackageFolderAndCliRoundTrip) {
  const std::string input = write_phantom();
  const std::string dir = scratch_dir();
  test::CliRun run = run_cli("pack " + input + " -o " + dir + "/pkg --no-viewer --threads 2");
  ASSERT_EQ(run.status, 0) << run.err;
  run = run_cli("export " + dir + "/pkg -o " + dir + "/out.glb --json");
  ASSERT_EQ(run.status, 0) << run.err;
  const json summary = json::parse(run.out);
  Result<PackageData> package = load_package(dir + "/pkg");
  ASSERT_TRUE(package.ok()) << package.status().message();
  EXPECT_EQ(summary["parts"], package->manifest.parts.size());
  EXPECT_GT(summary["mirrored_instances"].get<int>(), 0);
  EXPECT_LE(summary["max_deviation"].get<double>(), summary["error_bound"].get<double>());
  ReadOptions options;
  options.weld = false;
  Result<Scene> package_scene = read_package(dir + "/pkg");
  ASSERT_TRUE(package_scene.ok());
  std::map<std::string, Mesh> reference;
  for (Mesh& m : package_scene.value().parts) reference[m.name] = std::move(m);
  ExportReport report;
  report.error_bound = summary["error_bound"];
  report.max_deviation = summary["max_deviation"];
  expect_reads_back(dir + "/out.glb", package.value(), reference, report);

  // osteon info reads it back: every part and triangle.
  run = run_cli("info --json " + dir + "/out.glb");
  ASSERT_EQ(run.status, 0) << run.err;
  const json info = json::parse(run.out);
  EXPECT_EQ(info["parts"].size(), package->manifest.parts.size());
  // Packing the inputs in memory gives the same parts.
  run = run_cli("export " + input + " -o " + dir + "/direct.gltf --threads 2 --no-compress");
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_NE(run.out.find(" parts ("), std::string::npos);
  EXPECT_TRUE(fs::exists(dir + "/direct.bin"));
  run = run_cli("info --json " + dir + "/direct.gltf");
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(json::parse(run.out)["parts"].size(), package->manifest.parts.size());
}

/// Every file below `dir`, for "nothing was left behind".
std::vector<std::string> files_in(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    names.push_back(fs::relative(entry.path(), dir).string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

TEST(Export, RefusesBadInputsAndLeavesNothing) {
  const std::string input = write_phantom(1);
  const std::string dir = scratch_dir();
  test::CliRun run = run_cli("pack " + input + " -o " + dir + "/pkg --no-viewer --no-lod");
  ASSERT_EQ(run.status, 0) << run.err;
  const std::string out = scratch_dir();

  // An output in a missing folder.
  run = run_cli("export " + dir + "/pkg -o " + out + "/missing/x.glb");
  EXPECT_EQ(run.status, 2);
  EXPECT_EQ(run.err, "osteon: error: " + out + "/missing/x.glb: cannot write: the folder " + out +
                         "/missing does not exist\n");
  // Another extension.
  run = run_cli("export " + dir + "/pkg -o " + out + "/x.obj");
  EXPECT_EQ(run.status, 2);
  EXPECT_EQ(run.err, "osteon: error: " + out + "/x.obj: the output must end in .glb or .gltf\n");
  // An input it cannot read.
  run = run_cli("export " + dir + "/absent -o " + out + "/x.glb");
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("osteon: error: " + dir + "/absent: "), std::string::npos) << run.err;
  // A hostile manifest: a chunk outside the package.
  const std::string manifest_path = dir + "/pkg/manifest.json";
  std::vector<uint8_t> bytes = read_bytes(manifest_path);
  json manifest = json::parse(bytes.begin(), bytes.end());
  manifest["chunks"][0]["file"] = "../../../etc/passwd";
  test::write_bytes(manifest_path, manifest.dump());
  run = run_cli("export " + dir + "/pkg -o " + out + "/x.glb");
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("osteon: error: " + manifest_path + ": chunks[0].file"), std::string::npos)
      << run.err;
  // A chunk of another size than the manifest says.
  manifest = json::parse(bytes.begin(), bytes.end());
  const std::string chunk = dir + "/pkg/" + manifest["chunks"][0]["file"].get<std::string>();
  test::write_bytes(manifest_path, manifest.dump());
  std::vector<uint8_t> chunk_bytes = read_bytes(chunk);
  test::write_bytes(chunk, std::string(chunk_bytes.begin(), chunk_bytes.end() - 1));
  run = run_cli("export " + dir + "/pkg -o " + out + "/x.glb");
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("osteon: error: " + chunk + ": holds "), std::string::npos) << run.err;
  // A chunk whose stream is corrupt (same size, flipped byte): the decoder names it.
  chunk_bytes[chunk_bytes.size() / 2] ^= 0x5a;
  test::write_bytes(chunk, std::string(chunk_bytes.begin(), chunk_bytes.end()));
  run = run_cli("export " + dir + "/pkg -o " + out + "/x.gltf");
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("osteon: error: " + manifest_path + ": " +
                         manifest["chunks"][0]["file"].get<std::string>() + " at byte"),
            std::string::npos)
      << run.err;
  EXPECT_TRUE(files_in(out).empty()) << files_in(out).front();
}

}  // namespace export_test
}  // namespace
}  // namespace osteon
