// SPDX-License-Identifier: Apache-2.0
// The manifest's one writer and one parser (src/package), and the golden manifests in
// tests/data/manifests that the viewer's JavaScript parser is tested on too
// (web/test/manifest_golden.test.mjs): both accept the valid ones with the same counts, and
// refuse each bad one naming the same JSON path.
#include "osteon/package.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "fixtures.hpp"

namespace osteon {
namespace {
namespace package_manifest_test {

namespace fs = std::filesystem;
using test::read_bytes;

const std::string kGolden = std::string(OSTEON_SOURCE_DIR) + "/tests/data/manifests";

Result<Manifest> parse_file(const std::string& name) {
  const std::vector<uint8_t> bytes = read_bytes(kGolden + "/" + name);
  // Named as a package's manifest is, so messages read "manifest.json: <path>: <what>".
  return parse_manifest(bytes.data(), bytes.size(), "manifest.json");
}

TEST(PackageManifest, GoldenManifestsParseOrFailAtTheNamedField) {
  const std::vector<uint8_t> expected_bytes = read_bytes(kGolden + "/expected.json");
  const nlohmann::json expected =
      nlohmann::json::parse(expected_bytes.begin(), expected_bytes.end());
  size_t files = 0;
  for (const auto& entry : fs::directory_iterator(kGolden)) {
    const std::string name = entry.path().filename().string();
    if (name == "expected.json" || entry.path().extension() != ".json") continue;
    ++files;
    ASSERT_TRUE(expected.contains(name)) << name << " has no entry in expected.json";
    const nlohmann::json& want = expected[name];
    Result<Manifest> manifest = parse_file(name);
    if (want.contains("error")) {
      ASSERT_FALSE(manifest.ok()) << name << " parsed";
      const std::string path = want["error"];
      EXPECT_NE(manifest.status().message().find("manifest.json: " + path + ": "),
                std::string::npos)
          << name << ": " << manifest.status().message();
    } else {
      ASSERT_TRUE(manifest.ok()) << name << ": " << manifest.status().message();
      EXPECT_EQ(manifest->parts.size(), want["parts"].get<size_t>()) << name;
      EXPECT_EQ(manifest->components.size(), want["components"].get<size_t>()) << name;
      EXPECT_EQ(manifest->instances.size(), want["instances"].get<size_t>()) << name;
      EXPECT_EQ(manifest->chunks.size(), want["chunks"].get<size_t>()) << name;
    }
  }
  EXPECT_EQ(files, expected.size()) << "every entry of expected.json has its file";
  EXPECT_GE(files, 20u);
}

TEST(PackageManifest, FieldsReadAsWritten) {
  Result<Manifest> named = parse_file("valid_named_subset.json");
  ASSERT_TRUE(named.ok()) << named.status().message();
  EXPECT_EQ(named->unit, Unit::kMillimetre);
  ASSERT_EQ(named->parts.size(), 5u);
  bool mirrored = false;
  for (const ManifestInstance& instance : named->instances) {
    EXPECT_EQ(instance.mirror, determinant3(instance.matrix) < 0);
    EXPECT_GT(instance.error_bound, 0);
    mirrored = mirrored || instance.mirror;
  }
  EXPECT_TRUE(mirrored) << "the right femur is a mirrored copy of the left";
  std::vector<std::string> display;
  for (const ManifestPart& part : named->parts) display.push_back(part.display_name);
  EXPECT_NE(std::find(display.begin(), display.end(), "Left femur"), display.end());
  for (const ManifestComponent& c : named->components) {
    EXPECT_FALSE(c.bounds.empty);
    EXPECT_LE(c.offset + c.bytes, named->chunks[c.chunk].bytes);
  }
}

// Groups, languages, part paths, names and systems read as written, and write back the same
// (all but the error bounds, rounded up each time they are written).
TEST(PackageManifest, GroupsAndLanguagesReadAsWritten) {
  const std::vector<uint8_t> file = read_bytes(kGolden + "/valid_regions.json");
  Result<Manifest> m = parse_manifest(file.data(), file.size(), "manifest.json");
  ASSERT_TRUE(m.ok()) << m.status().message();
  EXPECT_EQ(m->languages, (std::vector<std::string>{"en", "la", "ja"}));
  ASSERT_EQ(m->groups.size(), 5u);
  EXPECT_EQ(m->groups[0].parent, -1);
  EXPECT_EQ(m->groups[2].name, "Left");
  EXPECT_EQ(m->groups[2].parent, 1);
  EXPECT_EQ(m->groups[1].names.at("la"), "Membrum inferius");
  EXPECT_TRUE(m->groups[2].names.empty());
  ASSERT_EQ(m->parts.size(), 5u);
  EXPECT_EQ(m->parts[0].path, 2);
  EXPECT_EQ(m->parts[0].names.at("la"), "Femur sinistrum");
  EXPECT_EQ(m->parts[0].system, "Skeletal system");
  EXPECT_EQ(m->parts[2].path, -1);
  EXPECT_TRUE(m->parts[2].names.empty());
  const auto without_bounds = [](nlohmann::json j) {
    for (const char* key : {"components", "instances"}) {
      for (nlohmann::json& entry : j[key]) entry.erase("error_bound");
    }
    return j;
  };
  const std::string text_back = write_manifest(m.value());
  EXPECT_EQ(without_bounds(nlohmann::json::parse(text_back)),
            without_bounds(nlohmann::json::parse(file.begin(), file.end())));

  // Without them nothing is written: older packages keep their bytes.
  Manifest plain = m.value();
  plain.languages.clear();
  plain.groups.clear();
  for (ManifestPart& part : plain.parts) {
    part.path = -1;
    part.names.clear();
    part.system.clear();
  }
  const std::string text = write_manifest(plain);
  for (const char* key : {"\"languages\"", "\"groups\"", "\"path\"", "\"names\"", "\"system\""}) {
    EXPECT_EQ(text.find(key), std::string::npos) << key;
  }
}

// What the writer writes, the parser reads back field for field; writing that again gives the
// same bytes for everything but the error bounds (rounded up each time they are written).
TEST(PackageManifest, WriterAndParserAgree) {
  Result<Manifest> original = parse_file("valid_phantom.json");
  ASSERT_TRUE(original.ok()) << original.status().message();
  const std::string text = write_manifest(original.value());
  Result<Manifest> back =
      parse_manifest(reinterpret_cast<const uint8_t*>(text.data()), text.size(), "manifest.json");
  ASSERT_TRUE(back.ok()) << back.status().message();
  ASSERT_EQ(back->parts.size(), original->parts.size());
  for (size_t p = 0; p < back->parts.size(); ++p) {
    EXPECT_EQ(back->parts[p].display_name, original->parts[p].display_name);
    EXPECT_EQ(back->parts[p].prototype, original->parts[p].prototype);
  }
  ASSERT_EQ(back->instances.size(), original->instances.size());
  for (size_t i = 0; i < back->instances.size(); ++i) {
    EXPECT_EQ(back->instances[i].matrix, original->instances[i].matrix);
    EXPECT_EQ(back->instances[i].component, original->instances[i].component);
    EXPECT_GE(back->instances[i].error_bound, original->instances[i].error_bound);
  }
  EXPECT_EQ(back->stream_order, original->stream_order);
  const std::vector<uint8_t> file = read_bytes(kGolden + "/valid_phantom.json");
  const nlohmann::json a = nlohmann::json::parse(file.begin(), file.end());
  nlohmann::json b = nlohmann::json::parse(text);
  for (nlohmann::json* m : {const_cast<nlohmann::json*>(&a), &b}) {
    for (nlohmann::json& c : (*m)["components"]) c.erase("error_bound");
    for (nlohmann::json& i : (*m)["instances"]) i.erase("error_bound");
  }
  EXPECT_EQ(a, b);
}

// The streams' version: written by pack, absent from packages written before it was recorded,
// and a version this build cannot decode refused up front.
TEST(PackageManifest, StreamVersionIsRecordedAndChecked) {
  Result<Manifest> older = parse_file("valid_phantom.json");
  ASSERT_TRUE(older.ok()) << older.status().message();
  EXPECT_EQ(older->stream_version, 0) << "not said";
  Manifest current = older.value();
  current.stream_version = kStreamVersion;
  const std::string text = write_manifest(current);
  EXPECT_EQ(nlohmann::json::parse(text)["stream_version"], kStreamVersion);
  Result<Manifest> back =
      parse_manifest(reinterpret_cast<const uint8_t*>(text.data()), text.size(), "manifest.json");
  ASSERT_TRUE(back.ok()) << back.status().message();
  EXPECT_EQ(back->stream_version, kStreamVersion);
  Result<Manifest> newer = parse_file("bad_stream_version.json");
  ASSERT_FALSE(newer.ok());
  EXPECT_EQ(newer.status().code(), ErrorCode::kUnsupported);
  EXPECT_NE(newer.status().message().find("decodes stream versions 1 to " +
                                          std::to_string(kStreamVersion) +
                                          ", the package's are version 9"),
            std::string::npos)
      << newer.status().message();
}

TEST(PackageManifest, NotJsonAndHugeInputsAreRefused) {
  const std::string not_json = "{\"format\": \"osteon-package\", ";
  Result<Manifest> m = parse_manifest(reinterpret_cast<const uint8_t*>(not_json.data()),
                                      not_json.size(), "manifest.json");
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.status().message().find("manifest.json"), std::string::npos);
  const std::string huge_count =
      R"({"format":"osteon-package","version":2,"unit":"mm","bounds":{"min":[0,0,0],"max":[1,1,1]},)"
      R"("chunks":[{"file":"c/000000000000000000000000.ostc","bytes":1e300}],"parts":[],)"
      R"("components":[],"instances":[],"stream_order":[]})";
  m = parse_manifest(reinterpret_cast<const uint8_t*>(huge_count.data()), huge_count.size(),
                     "manifest.json");
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.status().message().find("chunks[0].bytes"), std::string::npos)
      << m.status().message();
}

// Every number of a manifest is a float: one beyond a float's range (held as infinity, written
// back as null) and a matrix that only a double tells from singular (written back as zeros) are
// refused, at the field, so what the parser accepts the writer can write and the parser read again.
TEST(PackageManifest, NumbersAreFloats) {
  const std::vector<uint8_t> file = read_bytes(kGolden + "/valid_single_part.json");
  const nlohmann::json valid = nlohmann::json::parse(file.begin(), file.end());
  auto refused_at = [](const nlohmann::json& m) {
    const std::string text = m.dump();
    Result<Manifest> parsed =
        parse_manifest(reinterpret_cast<const uint8_t*>(text.data()), text.size(), "manifest.json");
    return parsed.ok() ? std::string("accepted") : parsed.status().message();
  };
  nlohmann::json m = valid;
  m["bounds"]["max"][2] = 1e39;
  EXPECT_NE(refused_at(m).find("manifest.json: bounds.max[2]: "), std::string::npos)
      << refused_at(m);
  m = valid;
  m["components"][0]["error_bound"] = -1e39;
  EXPECT_NE(refused_at(m).find("manifest.json: components[0].error_bound: "), std::string::npos)
      << refused_at(m);
  m = valid;
  m["instances"][0]["matrix"][13] = 3.5e38;
  EXPECT_NE(refused_at(m).find("manifest.json: instances[0].matrix[13]: "), std::string::npos)
      << refused_at(m);
  m = valid;
  for (int k : {0, 5, 10}) m["instances"][0]["matrix"][k] = 1e-50;
  EXPECT_NE(refused_at(m).find("manifest.json: instances[0].matrix: singular"), std::string::npos)
      << refused_at(m);
  // The largest float and a float's smallest step stay readable, and write back.
  m = valid;
  m["bounds"]["max"][2] = 3.4028235e38;  // the largest float, printed shortest (a bit above it)
  m["components"][0]["error_bound"] = 3.4028235e38;
  m["instances"][0]["error_bound"] = 3.4028235e38;
  for (int k : {0, 5, 10}) m["instances"][0]["matrix"][k] = 1e-30;
  const std::string text = m.dump();
  Result<Manifest> parsed =
      parse_manifest(reinterpret_cast<const uint8_t*>(text.data()), text.size(), "manifest.json");
  ASSERT_TRUE(parsed.ok()) << parsed.status().message();
  const std::string written = write_manifest(parsed.value());
  Result<Manifest> again = parse_manifest(reinterpret_cast<const uint8_t*>(written.data()),
                                          written.size(), "manifest.json");
  ASSERT_TRUE(again.ok()) << again.status().message();
  EXPECT_EQ(again->bounds.max.z, parsed->bounds.max.z);
  EXPECT_EQ(again->components[0].error_bound, parsed->components[0].error_bound);
}

}  // namespace package_manifest_test
}  // namespace
}  // namespace osteon
