// SPDX-License-Identifier: Apache-2.0
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>

#include "osteon/package.hpp"

// The one writer of manifest.json (docs/FORMAT.md "Package, version 3"). nlohmann::json keeps
// object keys sorted, so the same Manifest always gives the same bytes.

namespace osteon {

namespace {

using json = nlohmann::json;

/// `value` as the float nearest it, printed shortest: bounds and matrices are drawn in float, and
/// the manifest stays compact (12.3456, not 12.345600128173828).
double as_float(double value) {
  char text[32];
  const auto [end, ec] = std::to_chars(text, text + sizeof(text), static_cast<float>(value));
  return ec == std::errc() ? std::strtod(std::string(text, end).c_str(), nullptr) : value;
}

/// A bound rounded up to a float: never below `value`, but for a value above the largest float
/// (within half its step, which parse_manifest reads), written as the largest float: JSON has no
/// infinity.
double bound_up(double value) {
  float f = static_cast<float>(value);
  if (static_cast<double>(f) < value) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  if (std::isinf(f)) f = std::copysign(std::numeric_limits<float>::max(), f);
  return as_float(f);
}

json vec_json(const Vec3& v) {
  return json::array({as_float(v.x), as_float(v.y), as_float(v.z)});
}

json box_json(const Aabb& box) {
  return {{"min", vec_json(box.min)}, {"max", vec_json(box.max)}};
}

json matrix_json(const Mat4& m) {
  json out = json::array();
  for (double v : m) out.push_back(as_float(v));
  return out;
}

}  // namespace

std::string write_manifest(const Manifest& manifest) {
  json chunks = json::array();
  for (const ManifestChunk& chunk : manifest.chunks) {
    chunks.push_back({{"file", chunk.file}, {"bytes", chunk.bytes}});
  }
  json parts = json::array();
  for (size_t p = 0; p < manifest.parts.size(); ++p) {
    const ManifestPart& part = manifest.parts[p];
    json entry = {{"id", p},
                  {"name", part.name},
                  {"display_name", part.display_name},
                  {"group", part.group},
                  {"source", part.source},
                  {"triangles", part.triangles},
                  {"prototype", part.prototype}};
    if (part.has_color) entry["color"] = vec_json(part.color);
    if (part.path >= 0) entry["path"] = part.path;
    if (!part.names.empty()) entry["names"] = part.names;
    if (!part.system.empty()) entry["system"] = part.system;
    parts.push_back(std::move(entry));
  }
  json components = json::array();
  for (const ManifestComponent& c : manifest.components) {
    json entry = {{"id", c.id},
                  {"chunk", c.chunk},
                  {"offset", c.offset},
                  {"bytes", c.bytes},
                  {"triangles", c.triangles},
                  {"vertices", c.vertices},
                  {"bounds", box_json(c.bounds)},
                  {"error_bound", bound_up(c.error_bound)}};
    if (!c.levels.empty()) {
      json levels = json::array();
      for (const ManifestLevel& level : c.levels) {
        levels.push_back({{"chunk", level.chunk},
                          {"offset", level.offset},
                          {"bytes", level.bytes},
                          {"triangles", level.triangles},
                          {"vertices", level.vertices},
                          {"error", bound_up(level.error)}});
      }
      entry["levels"] = std::move(levels);
    }
    components.push_back(std::move(entry));
  }
  json instances = json::array();
  for (const ManifestInstance& instance : manifest.instances) {
    instances.push_back({{"part", instance.part},
                         {"component", instance.component},
                         {"matrix", matrix_json(instance.matrix)},
                         {"mirror", instance.mirror},
                         {"error_bound", bound_up(instance.error_bound)}});
  }
  json out;
  out["format"] = "osteon-package";
  out["version"] = kManifestVersion;
  if (manifest.stream_version != 0) out["stream_version"] = manifest.stream_version;
  out["chunks"] = std::move(chunks);
  out["unit"] = unit_name(manifest.unit);
  out["bounds"] = box_json(manifest.bounds);
  if (manifest.has_view) {
    out["view"] = {{"up", vec_json(manifest.view_up)}, {"eye", vec_json(manifest.view_eye)}};
  }
  // Groups and languages only when there are any: a package without them is byte-identical to
  // one written before they existed.
  if (!manifest.languages.empty()) out["languages"] = manifest.languages;
  if (!manifest.groups.empty()) {
    json groups = json::array();
    for (const ManifestGroup& group : manifest.groups) {
      json entry = {{"name", group.name}};
      if (group.parent >= 0) entry["parent"] = group.parent;
      if (!group.names.empty()) entry["names"] = group.names;
      groups.push_back(std::move(entry));
    }
    out["groups"] = std::move(groups);
  }
  out["parts"] = std::move(parts);
  out["components"] = std::move(components);
  out["instances"] = std::move(instances);
  out["stream_order"] = manifest.stream_order;
  // Compact: the manifest is the first thing a viewer fetches (about 1 KB per part).
  return out.dump() + "\n";
}

}  // namespace osteon
