// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <array>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "osteon/codec.hpp"
#include "osteon/io.hpp"
#include "osteon/mesh.hpp"
#include "osteon/pack.hpp"
#include "osteon/repeats.hpp"

// Reads a package back into its parts (docs/FORMAT.md "Package"): what a viewer draws, as meshes,
// so that `osteon compare ORIGINAL PACKAGE` measures the error of what is shown part by part.
// Every field the drawing needs is checked, with errors naming manifest.json and the JSON path;
// chunk files must be the c/<24 hex>.ostc names the format allows, so a hostile manifest cannot
// make the reader open files outside the package.

namespace osteon {

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

constexpr uint64_t kMaxManifestBytes = 256ull << 20;

bool is_chunk_file(const std::string& name) {
  if (name.size() != 2 + 24 + 5 || name.rfind("c/", 0) != 0) return false;
  if (name.compare(26, 5, ".ostc") != 0) return false;
  return std::all_of(name.begin() + 2, name.begin() + 26,
                     [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
}

Status bad(const std::string& manifest, const std::string& where, const std::string& what) {
  return error(ErrorCode::kInvalidData, manifest, where + ": " + what);
}

}  // namespace

bool is_package(const std::string& dir) {
  std::error_code ec;
  return fs::is_directory(dir, ec) && fs::is_regular_file(fs::path(dir) / "manifest.json", ec);
}

Result<Scene> read_package(const std::string& dir) {
  const std::string manifest_path = (fs::path(dir) / "manifest.json").string();
  OSTEON_ASSIGN_OR_RETURN(std::vector<uint8_t> text, read_file(manifest_path, kMaxManifestBytes));
  const json manifest = json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (manifest.is_discarded() || !manifest.is_object()) {
    return bad(manifest_path, "manifest", "not a JSON object");
  }
  if (manifest.value("format", "") != "osteon-package") {
    return bad(manifest_path, "format", "not \"osteon-package\"");
  }
  if (!manifest.contains("version") || !manifest["version"].is_number_integer() ||
      manifest["version"].get<int64_t>() != 2) {
    return error(ErrorCode::kUnsupported, manifest_path, "version: only version 2 is read");
  }
  const json& parts = manifest.value("parts", json());
  const json& components = manifest.value("components", json());
  const json& instances = manifest.value("instances", json());
  const json& chunks = manifest.value("chunks", json());
  if (!parts.is_array() || !components.is_array() || !instances.is_array() ||
      !chunks.is_array()) {
    return bad(manifest_path, "manifest",
               "parts, components, instances and chunks must be arrays");
  }
  Unit unit = Unit::kUnknown;
  if (manifest.contains("unit") && manifest["unit"].is_string()) {
    parse_unit(manifest["unit"].get<std::string>(), &unit);
  }

  // Chunks, read whole (each must be the size the manifest says).
  std::vector<std::vector<uint8_t>> chunk_bytes(chunks.size());
  for (size_t k = 0; k < chunks.size(); ++k) {
    const std::string where = "chunks[" + std::to_string(k) + "]";
    const json& chunk = chunks[k];
    if (!chunk.is_object() || !chunk.contains("file") || !chunk["file"].is_string() ||
        !chunk.contains("bytes") || !chunk["bytes"].is_number_unsigned()) {
      return bad(manifest_path, where, "needs a string file and a byte count");
    }
    const std::string file = chunk["file"];
    if (!is_chunk_file(file)) {
      return bad(manifest_path, where + ".file", "\"" + file + "\" is not a c/<24 hex>.ostc name");
    }
    const std::string path = (fs::path(dir) / file).string();
    OSTEON_ASSIGN_OR_RETURN(chunk_bytes[k], read_file(path, kMaxManifestBytes * 4));
    if (chunk_bytes[k].size() != chunk["bytes"].get<uint64_t>()) {
      return error(ErrorCode::kInvalidData, path,
                   "holds " + std::to_string(chunk_bytes[k].size()) + " bytes, the manifest says " +
                       std::to_string(chunk["bytes"].get<uint64_t>()));
    }
  }

  // Components, each decoded from its byte range of its chunk.
  std::map<std::string, Mesh> decoded;
  for (size_t i = 0; i < components.size(); ++i) {
    const std::string where = "components[" + std::to_string(i) + "]";
    const json& c = components[i];
    const bool fields = c.is_object() && c.contains("id") && c["id"].is_string() &&
                        c.contains("chunk") && c["chunk"].is_number_unsigned() &&
                        c.contains("offset") && c["offset"].is_number_unsigned() &&
                        c.contains("bytes") && c["bytes"].is_number_unsigned();
    if (!fields) return bad(manifest_path, where, "needs a string id, chunk, offset and bytes");
    const uint64_t chunk = c["chunk"], offset = c["offset"], bytes = c["bytes"];
    if (chunk >= chunk_bytes.size()) return bad(manifest_path, where + ".chunk", "out of range");
    const std::vector<uint8_t>& data = chunk_bytes[chunk];
    if (offset > data.size() || bytes > data.size() - offset) {
      return bad(manifest_path, where + ".offset",
                 "the byte range leaves " + chunks[chunk]["file"].get<std::string>());
    }
    const std::string source = (fs::path(dir) / chunks[chunk]["file"].get<std::string>()).string() +
                               " at byte " + std::to_string(offset);
    OSTEON_ASSIGN_OR_RETURN(Mesh mesh, decode(data.data() + offset, bytes, source));
    if (!decoded.emplace(c["id"].get<std::string>(), std::move(mesh)).second) {
      return bad(manifest_path, where + ".id", "a second component with this id");
    }
  }

  // Parts, each merged from its instances.
  std::vector<Scene> drawn(parts.size());
  for (size_t i = 0; i < instances.size(); ++i) {
    const std::string where = "instances[" + std::to_string(i) + "]";
    const json& instance = instances[i];
    if (!instance.is_object() || !instance.contains("part") ||
        !instance["part"].is_number_unsigned() || !instance.contains("component") ||
        !instance["component"].is_string()) {
      return bad(manifest_path, where, "needs part (an index) and component (an id)");
    }
    const uint64_t part = instance["part"];
    if (part >= parts.size()) return bad(manifest_path, where + ".part", "out of range");
    auto component = decoded.find(instance["component"].get<std::string>());
    if (component == decoded.end()) {
      return bad(manifest_path, where + ".component", "no component has this id");
    }
    std::array<double, 16> matrix{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    if (instance.contains("matrix")) {
      const json& m = instance["matrix"];
      if (!m.is_array() || m.size() != 16 ||
          !std::all_of(m.begin(), m.end(), [](const json& v) { return v.is_number(); })) {
        return bad(manifest_path, where + ".matrix", "needs 16 numbers");
      }
      for (size_t k = 0; k < 16; ++k) matrix[k] = m[k].get<double>();
    }
    drawn[part].parts.push_back(transform_mesh(component->second, matrix));
  }

  Scene scene;
  for (size_t p = 0; p < parts.size(); ++p) {
    const json& part = parts[p];
    if (!part.is_object() || !part.contains("name") || !part["name"].is_string()) {
      return bad(manifest_path, "parts[" + std::to_string(p) + "]", "needs a string name");
    }
    Mesh mesh = merge_parts(std::move(drawn[p]));
    mesh.name = part["name"];
    mesh.source = manifest_path;
    mesh.unit = unit;
    mesh.unit_source = unit == Unit::kUnknown ? UnitSource::kUnknown : UnitSource::kUser;
    scene.parts.push_back(std::move(mesh));
  }
  return scene;
}

}  // namespace osteon
