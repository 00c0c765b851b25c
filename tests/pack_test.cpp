// SPDX-License-Identifier: Apache-2.0
#include "osteon/pack.hpp"

#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "fixtures.hpp"
#include "osteon/codec.hpp"
#include "osteon/hausdorff.hpp"
#include "osteon/io.hpp"
#include "osteon/package.hpp"
#include "osteon/repeats.hpp"
#include "support/phantom.hpp"

namespace osteon {
namespace {
namespace pack_test {

namespace fs = std::filesystem;
using test::read_bytes;
using test::run_cli;
using test::scratch_dir;
using test::sha256_hex;
using test::write_phantom;

nlohmann::json read_manifest(const std::string& dir) {
  const std::vector<uint8_t> bytes = read_bytes(dir + "/manifest.json");
  return nlohmann::json::parse(bytes.begin(), bytes.end());
}

/// Every regular file below `dir`, relative path -> bytes.
std::map<std::string, std::vector<uint8_t>> tree(const std::string& dir) {
  std::map<std::string, std::vector<uint8_t>> files;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file()) {
      files[fs::relative(entry.path(), dir).string()] = read_bytes(entry.path().string());
    }
  }
  return files;
}

TEST(Pack, PhantomPackageReproducesEveryPart) {
  const std::string input = write_phantom();
  const std::string out = scratch_dir() + "/package";
  PackOptions options;
  options.output = out;
  options.max_triangles = 600;  // the phantom's bones have about 1k triangles: segment them
  options.chunk_bytes = 3000;   // several chunks of several components
  Result<PackReport> result = pack({input}, options);
  ASSERT_TRUE(result.ok()) << result.status().message();
  const PackReport& report = result.value();

  const nlohmann::json manifest = read_manifest(out);
  EXPECT_EQ(manifest["format"], "osteon-package");
  EXPECT_EQ(manifest["version"], kManifestVersion);
  EXPECT_EQ(manifest["parts"].size(), report.parts);
  EXPECT_EQ(manifest["components"].size(), report.components);
  EXPECT_EQ(manifest["instances"].size(), report.instances);
  EXPECT_EQ(manifest["stream_order"].size(), report.components);
  EXPECT_LT(report.prototypes, report.parts) << "the phantom has copies: some parts are instances";
  EXPECT_GT(report.components, report.prototypes) << "max_triangles 600 splits the bones";

  // manifest.json.gz holds the manifest's exact bytes.
  const std::vector<uint8_t> text = read_bytes(out + "/manifest.json");
  std::vector<uint8_t> gz = read_bytes(out + "/manifest.json.gz");
  EXPECT_EQ(gz.size(), report.manifest_gzip_bytes);
  EXPECT_LT(gz.size(), text.size() / 3);
  std::vector<uint8_t> unzipped(text.size() + 16);
  z_stream z{};
  ASSERT_EQ(inflateInit2(&z, 15 + 16), Z_OK);
  z.next_in = gz.data();
  z.avail_in = static_cast<uInt>(gz.size());
  z.next_out = unzipped.data();
  z.avail_out = static_cast<uInt>(unzipped.size());
  EXPECT_EQ(inflate(&z, Z_FINISH), Z_STREAM_END);
  unzipped.resize(z.total_out);
  inflateEnd(&z);
  EXPECT_TRUE(unzipped == text) << "manifest.json.gz is the manifest";

  // Chunk files: present, of the stated size and named by their hash; each component's byte
  // range decodes. Chunks are consecutive runs of the stream order at increasing offsets.
  std::vector<std::vector<uint8_t>> chunks;
  for (const nlohmann::json& chunk : manifest["chunks"]) {
    const std::string file = chunk["file"];
    chunks.push_back(read_bytes(out + "/" + file));
    ASSERT_EQ(chunks.back().size(), chunk["bytes"].get<size_t>()) << file;
    EXPECT_EQ(file, "c/" + sha256_hex(chunks.back()).substr(0, 24) + ".ostc");
  }
  EXPECT_EQ(report.files, chunks.size());
  std::map<std::string, Mesh> decoded;
  std::map<std::string, std::pair<size_t, size_t>> where;
  for (const nlohmann::json& c : manifest["components"]) {
    const size_t chunk = c["chunk"], offset = c["offset"], bytes = c["bytes"];
    ASSERT_LT(chunk, chunks.size());
    ASSERT_LE(offset + bytes, chunks[chunk].size());
    EXPECT_LE(c["triangles"].get<size_t>(), options.max_triangles);
    Result<Mesh> mesh = decode(chunks[chunk].data() + offset, bytes, "chunk");
    ASSERT_TRUE(mesh.ok()) << mesh.status().message();
    EXPECT_EQ(mesh->triangle_count(), c["triangles"].get<size_t>());
    decoded[c["id"]] = std::move(mesh.value());
    where[c["id"]] = {chunk, offset};
  }
  std::map<size_t, size_t> streams_in;
  for (const auto& [id, at] : where) ++streams_in[at.first];
  for (size_t k = 0; k < chunks.size(); ++k) {
    EXPECT_TRUE(chunks[k].size() <= options.chunk_bytes || streams_in[k] == 1)
        << "chunk " << k << ": " << chunks[k].size() << " bytes";
  }
  EXPECT_GT(chunks.size(), 1u);
  EXPECT_LT(chunks.size(), decoded.size());
  std::pair<size_t, size_t> last{0, 0};
  for (const std::string id : manifest["stream_order"]) {
    EXPECT_GE(where[id], last) << id << ": chunks follow the stream order";
    last = where[id];
  }

  // Stream order: decreasing summed projected area is not checkable from the manifest alone,
  // but it is a permutation of the component ids.
  std::vector<std::string> order = manifest["stream_order"];
  std::sort(order.begin(), order.end());
  std::vector<std::string> ids;
  for (const auto& [id, mesh] : decoded) ids.push_back(id);
  EXPECT_EQ(order, ids);

  // Each part drawn from its instances: the same triangle count, within the error bound.
  Result<Scene> scene = read_path(input);
  ASSERT_TRUE(scene.ok());
  std::map<std::string, const Mesh*> by_name;
  for (Mesh& part : scene->parts) {
    remove_degenerate_triangles(part);
    remove_unreferenced_vertices(part);
    by_name[part.name] = &part;
  }
  std::vector<Scene> drawn(manifest["parts"].size());
  std::vector<double> bound(manifest["parts"].size(), 0);
  for (const nlohmann::json& instance : manifest["instances"]) {
    const size_t part = instance["part"];
    ASSERT_LT(part, drawn.size());
    std::array<double, 16> matrix = instance["matrix"];
    drawn[part].parts.push_back(transform_mesh(decoded.at(instance["component"]), matrix));
    bound[part] = std::max(bound[part], instance["error_bound"].get<double>());
  }
  size_t measured = 0;
  for (size_t p = 0; p < drawn.size(); ++p) {
    const std::string name = manifest["parts"][p]["name"];
    ASSERT_TRUE(by_name.count(name)) << name;
    const Mesh& original = *by_name[name];
    Mesh merged = merge_parts(std::move(drawn[p]));
    EXPECT_EQ(merged.triangle_count(), original.triangle_count()) << name;
    if (p % 3 != 0) continue;  // a third of the parts: Hausdorff takes a while
    HausdorffOptions h;
    h.samples_per_face = 2;
    Result<HausdorffReport> distance = hausdorff(original, merged, h);
    ASSERT_TRUE(distance.ok()) << distance.status().message();
    // The repeat tolerance is a sampled bound: allow 10% over it.
    EXPECT_LE(distance->symmetric.max, 1.1 * bound[p] + 1e-6) << name;
    ++measured;
  }
  EXPECT_GT(measured, 2u);
}

TEST(Pack, SameInputGivesIdenticalBytes) {
  const std::string input = write_phantom();
  const std::string dir = scratch_dir();
  PackOptions options;
  options.output = dir + "/a";
  ASSERT_TRUE(pack({input}, options).ok());
  options.output = dir + "/b";
  ASSERT_TRUE(pack({input}, options).ok());
  const auto a = tree(dir + "/a");
  const auto b = tree(dir + "/b");
  EXPECT_GT(a.size(), 1u);
  EXPECT_TRUE(a == b) << "two packs of the same input differ";
}

TEST(Pack, ThreadCountDoesNotChangeTheBytes) {
  const std::string input = write_phantom();
  const std::string dir = scratch_dir();
  PackOptions options;
  options.max_triangles = 400;
  options.threads = 1;
  options.output = dir + "/one";
  ASSERT_TRUE(pack({input}, options).ok());
  options.threads = 4;
  options.output = dir + "/four";
  ASSERT_TRUE(pack({input}, options).ok());
  EXPECT_TRUE(tree(dir + "/one") == tree(dir + "/four"));
}

// The real BodyParts3D skeleton with its names, at a 0.05 mm coordinate precision.
TEST(Pack, BodyParts3DSkeletonWithNames) {
  OSTEON_REQUIRE_SHARED_DATA(data);
  const std::string root = data + "/aHer-dev__3DAnatomy";
  PackOptions options;
  options.output = scratch_dir() + "/bp3d";
  options.precision = 0.05;
  options.names = root + "/meta.json";
  Result<PackReport> result = pack({root + "/models/bones"}, options);
  ASSERT_TRUE(result.ok()) << result.status().message();
  const PackReport& report = result.value();
  EXPECT_EQ(report.parts, 235u);
  EXPECT_EQ(report.triangles_out, report.triangles_in);
  EXPECT_LT(report.output_bytes, report.input_bytes / 8);

  const nlohmann::json manifest = read_manifest(options.output);
  EXPECT_EQ(manifest["unit"], "mm");
  std::map<std::string, std::string> group_of;
  for (const nlohmann::json& part : manifest["parts"]) {
    group_of[part["display_name"]] = part["group"];
  }
  EXPECT_EQ(group_of.size(), 235u) << "every bone has its own display name";
  for (const char* bone : {"Frontal bone", "Occipital bone", "Mandible", "Left femur"}) {
    ASSERT_TRUE(group_of.count(bone)) << bone;
    EXPECT_EQ(group_of[bone], "bones") << bone;
  }
  std::map<std::string, double> area;
  for (const nlohmann::json& c : manifest["components"]) {
    EXPECT_LE(c["triangles"].get<uint32_t>(), options.max_triangles);
    EXPECT_LE(c["error_bound"].get<double>(), std::sqrt(3.0) * 0.05 * 1.000001);
    const std::array<double, 3> lo = c["bounds"]["min"], hi = c["bounds"]["max"];
    const double dx = hi[0] - lo[0], dy = hi[1] - lo[1], dz = hi[2] - lo[2];
    area[c["id"]] = std::max({dx * dy, dy * dz, dx * dz});
  }
  // Without repeats every component has one instance in its own frame: the stream order is by
  // decreasing projected box area.
  const std::vector<std::string> order = manifest["stream_order"];
  ASSERT_EQ(order.size(), area.size());
  if (report.prototypes == report.parts) {
    for (size_t i = 1; i < order.size(); ++i) EXPECT_GE(area[order[i - 1]], area[order[i]]);
  }
}

TEST(Pack, NamesFromCsvAndJson) {
  const std::string input = write_phantom();
  const std::string dir = scratch_dir();
  test::write_bytes(dir + "/names.csv",
                    "file,display_name,group\nfemur_l,\"Left femur, bone\",legs\n");
  PackOptions options;
  options.output = dir + "/csv";
  options.names = dir + "/names.csv";
  ASSERT_TRUE(pack({input}, options).ok());
  bool found = false;
  const nlohmann::json from_csv = read_manifest(options.output);
  for (const nlohmann::json& part : from_csv["parts"]) {
    if (part["name"] != "femur_l") {
      EXPECT_EQ(part["display_name"], part["name"]);
      continue;
    }
    found = true;
    EXPECT_EQ(part["display_name"], "Left femur, bone");
    EXPECT_EQ(part["group"], "legs");
  }
  EXPECT_TRUE(found) << "the phantom has no femur_l";

  // BodyParts3D's meta.json shape: an array of {filename, label, group}.
  test::write_bytes(
      dir + "/meta.json",
      R"([{"filename": "bones/femur_l.glb", "label": "Left femur", "group": "bones"}])");
  options.output = dir + "/json";
  options.names = dir + "/meta.json";
  ASSERT_TRUE(pack({input}, options).ok());
  const nlohmann::json from_json = read_manifest(options.output);
  for (const nlohmann::json& part : from_json["parts"]) {
    if (part["name"] == "femur_l") {
      EXPECT_EQ(part["display_name"], "Left femur");
    }
  }
}

// Regions and languages from the names file: each path becomes groups (shared prefixes once,
// in the parts' order, after their parents), "group" the path joined by " / ", and names in
// other languages kept per part and per group.
TEST(Pack, GroupsAndLanguagesFromTheNamesFile) {
  const std::string input = write_phantom();
  const std::string dir = scratch_dir();
  PackOptions options;
  options.output = dir + "/regions";
  options.names = std::string(OSTEON_SOURCE_DIR) + "/tests/data/names/regions.json";
  ASSERT_TRUE(pack({input}, options).ok());
  const nlohmann::json m = read_manifest(options.output);
  EXPECT_EQ(m["languages"], nlohmann::json::array({"en", "la", "ja"}));
  std::vector<std::string> tree;
  for (const nlohmann::json& g : m["groups"]) {
    const int parent = g.contains("parent") ? g["parent"].get<int>() : -1;
    tree.push_back((parent < 0 ? std::string() : tree[size_t(parent)] + " / ") +
                   g["name"].get<std::string>());
  }
  EXPECT_EQ(tree, (std::vector<std::string>{
                      "Skeleton", "Skeleton / Lower limb", "Skeleton / Lower limb / Left",
                      "Skeleton / Lower limb / Right", "Skeleton / Vertebral column"}));
  EXPECT_EQ(m["groups"][1]["names"]["la"], "Membrum inferius");
  EXPECT_EQ(m["groups"][3]["names"]["la"], "Dexter");
  size_t checked = 0;
  for (const nlohmann::json& part : m["parts"]) {
    const std::string name = part["name"];
    if (name == "femur_l") {
      EXPECT_EQ(part["path"], 2);
      EXPECT_EQ(part["group"], "Skeleton / Lower limb / Left");
      EXPECT_EQ(part["names"]["ja"], "\xE5\xB7\xA6\xE5\xA4\xA7\xE8\x85\xBF\xE9\xAA\xA8");
      EXPECT_EQ(part["system"], "Skeletal system");
      ++checked;
    } else if (name == "vertebra_l2") {
      EXPECT_EQ(part["path"], 4);
      EXPECT_EQ(part["group"], "Skeleton / Vertebral column");
      EXPECT_FALSE(part.contains("names"));
      EXPECT_FALSE(part.contains("system"));
      ++checked;
    } else if (name == "skull") {
      EXPECT_FALSE(part.contains("path"));  // a plain group string, no path
      EXPECT_EQ(part["group"], "head");
      ++checked;
    } else if (name == "pelvis") {
      EXPECT_FALSE(part.contains("path"));  // not in the names file
      EXPECT_EQ(part["group"], "");
      ++checked;
    }
  }
  EXPECT_EQ(checked, 4u);

  // A CSV header names its columns: path, system, name:<tag>; display_name:<tag> names the
  // display names' language.
  test::write_bytes(
      dir + "/names.csv",
      "stem,display_name:en,path,system,name:la\n"
      "femur_l,Left femur,Skeleton / Lower limb / Left,Skeletal system,Femur sinistrum\n"
      "skull,Skull,Skeleton / Head,,\n");
  options.output = dir + "/csv";
  options.names = dir + "/names.csv";
  ASSERT_TRUE(pack({input}, options).ok());
  const nlohmann::json csv = read_manifest(options.output);
  EXPECT_EQ(csv["languages"], nlohmann::json::array({"en", "la"}));
  EXPECT_EQ(csv["groups"].size(), 4u);
  for (const nlohmann::json& part : csv["parts"]) {
    if (part["name"] == "femur_l") {
      EXPECT_EQ(part["names"]["la"], "Femur sinistrum");
    }
    if (part["name"] == "skull") {
      EXPECT_FALSE(part.contains("system"));
    }
  }

  // Without a list of languages, they are "und" (the display names') and the tags used.
  test::write_bytes(dir + "/unlisted.json",
                    R"([{"file": "skull", "names": {"la": "Cranium", "de": "Schaedel"}}])");
  options.output = dir + "/unlisted";
  options.names = dir + "/unlisted.json";
  ASSERT_TRUE(pack({input}, options).ok());
  EXPECT_EQ(read_manifest(options.output)["languages"], nlohmann::json::array({"und", "de", "la"}));

  // Bad names files name the file and the entry; no package is left.
  const std::vector<std::pair<std::string, std::string>> bad = {
      {R"({"languages": ["en"], "parts": [{"file": "skull", "names": {"la": "Cranium"}}]})",
       "skull: names.la: \"la\" is not in languages"},
      {R"({"languages": ["en", "en"], "parts": []})", "languages: \"en\" appears twice"},
      {R"({"languages": ["english"], "parts": []})", "languages[0]: expected a language tag"},
      {R"([{"file": "skull", "path": ["Skeleton", ""]}])", "skull: path[1]: an empty group name"},
      {R"([{"file": "skull", "path": 7}])", "skull: path: expected an array of group names"},
      {R"([{"file": "skull", "names": {"la": 7}}])", "skull: names.la: expected a string"},
      {R"([{"file": "skull", "path": []}])", "skull: path: empty"},
      {R"([{"file": "skull", "path": "Skeleton / Head / Skeleton"}])",
       "skull: path[2]: \"Skeleton\" is inside itself (path[0]): a cycle in the hierarchy"},
      {"file,display_name,side\nskull,Skull,left\n",
       "header: column 3 (\"side\"): unknown; expected display_name, name:<tag>, group, color, "
       "path or system"},
      {"file,display_name,path\nskull,Skull,\n", "skull: path: empty"},
  };
  for (size_t k = 0; k < bad.size(); ++k) {
    const std::string file = dir + "/bad" + std::to_string(k) + ".json";
    test::write_bytes(file, bad[k].first);
    options.output = dir + "/bad" + std::to_string(k);
    options.names = file;
    const Result<PackReport> report = pack({input}, options);
    ASSERT_FALSE(report.ok()) << bad[k].first;
    EXPECT_NE(report.status().message().find(file + ": " + bad[k].second), std::string::npos)
        << report.status().message();
    EXPECT_FALSE(fs::exists(options.output + "/manifest.json"));
  }
  std::string deep = "[{\"file\": \"skull\", \"path\": [";
  for (int k = 0; k <= kMaxGroupDepth; ++k)
    deep += (k ? ", \"g" : "\"g") + std::to_string(k) + "\"";
  test::write_bytes(dir + "/deep.json", deep + "]}]");
  options.output = dir + "/deep";
  options.names = dir + "/deep.json";
  const Result<PackReport> report = pack({input}, options);
  ASSERT_FALSE(report.ok());
  EXPECT_NE(report.status().message().find("skull: path: 33 groups, at most 32"), std::string::npos)
      << report.status().message();
}

TEST(Pack, CliSummaryAndBadInput) {
  const std::string input = write_phantom();
  const std::string out = scratch_dir() + "/cli";
  const std::string viewer = scratch_dir() + "/viewer";
  fs::create_directories(viewer + "/assets");
  test::write_bytes(viewer + "/index.html", "<!doctype html><title>osteon</title>");
  test::write_bytes(viewer + "/assets/viewer-1234.js", "console.log('osteon')");
  test::CliRun run =
      run_cli("pack " + input + " -o " + out + " --bits 12 --json --viewer " + viewer);
  ASSERT_EQ(run.status, 0) << run.err;
  const nlohmann::json summary = nlohmann::json::parse(run.out);
  EXPECT_EQ(summary["viewer_files"].get<size_t>(), 2u);
  EXPECT_EQ(summary["viewer_bytes"].get<uint64_t>(), 36u + 21u);
  EXPECT_EQ(read_bytes(out + "/assets/viewer-1234.js").size(), 21u);
  EXPECT_TRUE(fs::exists(out + "/index.html"));
  EXPECT_GT(summary["input_bytes"].get<uint64_t>(), summary["output_bytes"].get<uint64_t>());
  EXPECT_GT(summary["instances"].get<size_t>(), 0u);
  EXPECT_TRUE(summary["time_ms"].contains("encode"));
  EXPECT_TRUE(fs::exists(out + "/manifest.json"));

  const std::string missing_out = scratch_dir() + "/never";
  test::CliRun missing = run_cli("pack " + input + " /nonexistent/femur.stl -o " + missing_out);
  EXPECT_EQ(missing.status, 2);
  EXPECT_NE(missing.err.find("osteon: error:"), std::string::npos) << missing.err;
  EXPECT_FALSE(fs::exists(missing_out)) << "nothing is written when an input fails";

  test::CliRun both =
      run_cli("pack " + input + " -o " + missing_out + " --bits 12 --precision 0.1");
  EXPECT_EQ(both.status, 2);

  // A viewer folder that is missing, or that would overwrite the package's own files.
  test::CliRun no_viewer = run_cli("pack " + input + " -o " + missing_out + " --viewer " +
                                   scratch_dir() + "/no-such-viewer");
  EXPECT_EQ(no_viewer.status, 2);
  EXPECT_NE(no_viewer.err.find("no-such-viewer"), std::string::npos) << no_viewer.err;
  EXPECT_NE(no_viewer.err.find("npm run build:viewer"), std::string::npos) << no_viewer.err;
  EXPECT_FALSE(fs::exists(missing_out));
  test::write_bytes(viewer + "/manifest.json", "{}");
  test::CliRun clash = run_cli("pack " + input + " -o " + missing_out + " --viewer " + viewer);
  EXPECT_EQ(clash.status, 2);
  EXPECT_NE(clash.err.find("manifest.json"), std::string::npos) << clash.err;
  EXPECT_FALSE(fs::exists(missing_out));

  // --no-viewer writes the data only; --no-repeats stores every part.
  test::CliRun data_only =
      run_cli("pack " + input + " -o " + missing_out + " --no-viewer --no-repeats --json");
  ASSERT_EQ(data_only.status, 0) << data_only.err;
  const nlohmann::json plain = nlohmann::json::parse(data_only.out);
  EXPECT_EQ(plain["viewer_files"].get<size_t>(), 0u);
  EXPECT_EQ(plain["prototypes"], plain["parts"]);
  EXPECT_FALSE(fs::exists(missing_out + "/index.html"));
}

TEST(Pack, ReportsEveryStageInOrder) {
  const std::string input = write_phantom();
  PackOptions options;
  options.output = scratch_dir() + "/progress";
  options.max_triangles = 500;  // the phantom's larger bones are segmented
  std::vector<PackStage> stages;
  std::map<PackStage, std::pair<uint64_t, uint64_t>> last;
  options.progress = [&](PackStage stage, uint64_t done, uint64_t total) {
    if (stages.empty() || stages.back() != stage) stages.push_back(stage);
    EXPECT_LE(done, total) << stage_name(stage);
    last[stage] = {done, total};
  };
  Result<PackReport> report = pack({input}, options);
  ASSERT_TRUE(report.ok()) << report.status().message();
  const std::vector<PackStage> expected = {PackStage::kRead,    PackStage::kClean,
                                           PackStage::kRepeats, PackStage::kSegment,
                                           PackStage::kLevels,  PackStage::kEncode,
                                           PackStage::kWrite};
  EXPECT_EQ(stages, expected);
  for (const auto& [stage, counts] : last) {
    EXPECT_EQ(counts.first, counts.second) << stage_name(stage) << " ends complete";
  }
  EXPECT_EQ(last[PackStage::kEncode].second, report.value().components);
  EXPECT_GT(last[PackStage::kSegment].second, 0u);
}

// A package reads back as the parts the viewer draws: read_path recognises it, compare measures it.
TEST(Pack, PackageReadsBackPartByPart) {
  const std::string input = write_phantom();
  const std::string out = scratch_dir() + "/readback";
  PackOptions options;
  options.output = out;
  options.max_triangles = 500;
  ASSERT_TRUE(pack({input}, options).ok());
  ASSERT_TRUE(is_package(out));
  Result<Scene> original = read_path(input);
  ASSERT_TRUE(original.ok());
  Result<Scene> back = read_path(out);
  ASSERT_TRUE(back.ok()) << back.status().message();
  ASSERT_EQ(back->parts.size(), original->parts.size());
  for (size_t p = 0; p < back->parts.size(); ++p) {
    EXPECT_EQ(back->parts[p].name, original->parts[p].name);
    EXPECT_EQ(back->parts[p].triangle_count(), original->parts[p].triangle_count());
  }
  test::CliRun run = run_cli("compare " + input + " " + out + " --json");
  ASSERT_EQ(run.status, 0) << run.err;
  const nlohmann::json report = nlohmann::json::parse(run.out);
  EXPECT_NE(run.out.find("femur_l"), std::string::npos) << "matched part by part";
}

// A hostile or broken manifest gives an error naming manifest.json and the field; nothing outside
// the package is opened.
TEST(Pack, BadManifestIsRefused) {
  const std::string input = write_phantom(1);
  const std::string out = scratch_dir() + "/bad";
  PackOptions options;
  options.output = out;
  ASSERT_TRUE(pack({input}, options).ok());
  const std::vector<uint8_t> good_bytes = read_bytes(out + "/manifest.json");
  const std::string good(good_bytes.begin(), good_bytes.end());
  const nlohmann::json manifest = nlohmann::json::parse(good);
  struct Case {
    const char* what;
    std::function<void(nlohmann::json&)> edit;
    const char* expect;
  };
  const std::vector<Case> cases = {
      {"escaping file", [](nlohmann::json& m) { m["chunks"][0]["file"] = "../secret.ostc"; },
       "chunks[0].file"},
      {"range outside its chunk",
       [](nlohmann::json& m) { m["components"][0]["offset"] = 1u << 30; }, "components[0].offset"},
      {"chunk out of range", [](nlohmann::json& m) { m["components"][1]["chunk"] = 99; },
       "components[1].chunk"},
      {"unknown component", [](nlohmann::json& m) { m["instances"][0]["component"] = "zz"; },
       "instances[0].component"},
      {"part out of range", [](nlohmann::json& m) { m["instances"][1]["part"] = 1000000; },
       "instances[1].part"},
      {"short matrix", [](nlohmann::json& m) { m["instances"][0]["matrix"] = {1, 2, 3}; },
       "instances[0].matrix"},
      {"version", [](nlohmann::json& m) { m["version"] = 1; }, "version"},
      {"not a package", [](nlohmann::json& m) { m["format"] = "glTF"; }, "format"},
  };
  for (const Case& c : cases) {
    nlohmann::json edited = manifest;
    c.edit(edited);
    test::write_bytes(out + "/manifest.json", edited.dump());
    Result<Scene> scene = read_package(out);
    ASSERT_FALSE(scene.ok()) << c.what;
    EXPECT_NE(scene.status().message().find("manifest.json"), std::string::npos) << c.what;
    EXPECT_NE(scene.status().message().find(c.expect), std::string::npos)
        << c.what << ": " << scene.status().message();
  }
  test::write_bytes(out + "/manifest.json", "{\"format\": \"osteon-package\", ");
  EXPECT_FALSE(read_package(out).ok());
  // A flipped byte inside one stream: the decoder's error names the chunk and the offset.
  test::write_bytes(out + "/manifest.json", good);
  {
    const size_t chunk = manifest["components"][0]["chunk"];
    const std::string chunk_file = manifest["chunks"][chunk]["file"];
    const size_t offset = manifest["components"][0]["offset"];
    const size_t bytes = manifest["components"][0]["bytes"];
    std::vector<uint8_t> data = read_bytes(out + "/" + chunk_file);
    const std::vector<uint8_t> saved = data;
    data[offset + bytes / 2] ^= 0x5a;
    test::write_bytes(out + "/" + chunk_file, std::string(data.begin(), data.end()));
    Result<Scene> corrupt = read_package(out);
    ASSERT_FALSE(corrupt.ok());
    EXPECT_NE(corrupt.status().message().find(chunk_file + " at byte " + std::to_string(offset)),
              std::string::npos)
        << corrupt.status().message();
    test::write_bytes(out + "/" + chunk_file, std::string(saved.begin(), saved.end()));
  }
  // A missing chunk file names the file.
  test::write_bytes(out + "/manifest.json", good);
  const std::string file = manifest["chunks"][0]["file"];
  fs::remove(out + "/" + file);
  Result<Scene> missing = read_package(out);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.status().message().find(file), std::string::npos) << missing.status().message();
}

}  // namespace pack_test
}  // namespace
}  // namespace osteon
