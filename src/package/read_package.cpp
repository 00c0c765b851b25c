// SPDX-License-Identifier: Apache-2.0
#include <filesystem>
#include <string>
#include <system_error>
#include <unordered_map>
#include <utility>
#include <vector>

#include "osteon/codec.hpp"
#include "osteon/io.hpp"
#include "osteon/mesh.hpp"
#include "osteon/package.hpp"

// Reads a package back into its parts (docs/FORMAT.md "Package"): what a viewer draws, as meshes,
// so that `osteon compare ORIGINAL PACKAGE` measures the error of what is shown part by part.
// parse_manifest checks every field first; only the chunk files it accepted (c/<24 hex>.ostc) are
// opened, so a hostile manifest cannot make the reader open files outside the package.

namespace osteon {

namespace {

namespace fs = std::filesystem;

constexpr uint64_t kMaxManifestBytes = 256ull << 20;
constexpr uint64_t kMaxChunkBytes = 4 * kMaxManifestBytes;

}  // namespace

bool is_package(const std::string& dir) {
  std::error_code ec;
  return fs::is_directory(dir, ec) && fs::is_regular_file(fs::path(dir) / "manifest.json", ec);
}

Result<PackageData> load_package(const std::string& dir) {
  PackageData package;
  package.source = (fs::path(dir) / "manifest.json").string();
  OSTEON_ASSIGN_OR_RETURN(std::vector<uint8_t> text, read_file(package.source, kMaxManifestBytes));
  OSTEON_ASSIGN_OR_RETURN(package.manifest,
                          parse_manifest(text.data(), text.size(), package.source));
  // Chunks, read whole (each must be the size the manifest says).
  const Manifest& manifest = package.manifest;
  package.chunks.resize(manifest.chunks.size());
  for (size_t k = 0; k < manifest.chunks.size(); ++k) {
    const ManifestChunk& chunk = manifest.chunks[k];
    const std::string path = (fs::path(dir) / chunk.file).string();
    OSTEON_ASSIGN_OR_RETURN(package.chunks[k], read_file(path, kMaxChunkBytes));
    if (package.chunks[k].size() != chunk.bytes) {
      return error(ErrorCode::kInvalidData, path,
                   "holds " + std::to_string(package.chunks[k].size()) +
                       " bytes, the manifest says " + std::to_string(chunk.bytes));
    }
  }
  return package;
}

Result<Scene> read_package(const std::string& dir, int level) {
  OSTEON_ASSIGN_OR_RETURN(PackageData package, load_package(dir));
  const Manifest& manifest = package.manifest;
  const std::string& manifest_path = package.source;
  const std::vector<std::vector<uint8_t>>& chunk_bytes = package.chunks;

  // Components, each decoded from its byte range of its chunk (parse_manifest checked the
  // ranges), at the level asked for.
  std::vector<Mesh> decoded;
  decoded.reserve(manifest.components.size());
  for (const ManifestComponent& c : manifest.components) {
    uint64_t chunk = c.chunk, offset = c.offset, bytes = c.bytes;
    if (level >= 0 && static_cast<size_t>(level) < c.levels.size()) {
      const ManifestLevel& l = c.levels[static_cast<size_t>(level)];
      chunk = l.chunk;
      offset = l.offset;
      bytes = l.bytes;
    }
    const std::string source = (fs::path(dir) / manifest.chunks[chunk].file).string() +
                               " at byte " + std::to_string(offset);
    OSTEON_ASSIGN_OR_RETURN(Mesh mesh, decode(chunk_bytes[chunk].data() + offset, bytes, source));
    decoded.push_back(std::move(mesh));
  }
  std::unordered_map<std::string, size_t> index_of;
  for (size_t c = 0; c < manifest.components.size(); ++c) {
    index_of.emplace(manifest.components[c].id, c);
  }

  // Parts, each merged from its instances.
  std::vector<Scene> drawn(manifest.parts.size());
  for (const ManifestInstance& instance : manifest.instances) {
    const Mesh& component = decoded[index_of.at(instance.component)];
    drawn[instance.part].parts.push_back(transform_mesh(component, instance.matrix));
  }
  Scene scene;
  for (size_t p = 0; p < manifest.parts.size(); ++p) {
    Mesh mesh = merge_parts(std::move(drawn[p]));
    mesh.name = manifest.parts[p].name;
    mesh.source = manifest_path;
    mesh.unit = manifest.unit;
    mesh.unit_source = manifest.unit == Unit::kUnknown ? UnitSource::kUnknown : UnitSource::kUser;
    scene.parts.push_back(std::move(mesh));
  }
  return scene;
}

}  // namespace osteon
