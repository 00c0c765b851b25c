// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "osteon/package.hpp"
#include "package/package_internal.hpp"

// The one C++ parser of manifest.json (docs/FORMAT.md "Package, version 3"; version 2 too). It checks what the
// viewer's parser (web/viewer/manifest.mjs) checks, in the same order and naming the same JSON
// path, so a manifest is refused alike by both; tests/data/manifests holds the golden cases both
// are tested on. The manifest comes from a folder or a server: nothing in it is trusted.

namespace osteon {

namespace detail {

bool is_language_tag(const std::string& tag) {
  const auto alpha = [](char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z'); };
  const auto alnum = [&](char c) { return alpha(c) || (c >= '0' && c <= '9'); };
  size_t i = 0;
  while (i < tag.size() && alpha(tag[i])) ++i;
  if (i < 2 || i > 3) return false;
  while (i < tag.size()) {
    if (tag[i] != '-') return false;
    const size_t start = ++i;
    while (i < tag.size() && alnum(tag[i])) ++i;
    if (i - start < 1 || i - start > 8) return false;
  }
  return true;
}

}  // namespace detail

namespace {

using json = nlohmann::json;

/// The first error met, with the JSON path; parsing stops at it.
class Checker {
 public:
  explicit Checker(const std::string& source) : source_(source) {}

  bool failed() const { return !status_.ok(); }
  Status status() const { return status_; }

  /// Records an error at `where` (first one wins); returns false for `return` chains.
  bool fail(const std::string& where, const std::string& what,
            ErrorCode code = ErrorCode::kInvalidData) {
    if (!failed()) status_ = error(code, source_, where + ": " + what);
    return false;
  }

  bool object(const json& v, const std::string& where) {
    return v.is_object() || fail(where, "expected an object");
  }
  bool number(const json& v, const std::string& where, double* out) {
    // JSON has no NaN or infinity; a number too large for a double parses as one.
    if (!v.is_number() || !std::isfinite(v.get<double>())) {
      return fail(where, "expected a finite number, got " + shown(v));
    }
    // Every number of the manifest is a float (drawn in float, written as the nearest float):
    // one that rounds to a float's infinity would be read, and written back, as infinity.
    if (std::isinf(static_cast<float>(v.get<double>()))) {
      return fail(where, shown(v) + " is beyond a float's range");
    }
    *out = v.get<double>();
    return true;
  }
  /// A non-negative integer that a double holds exactly (the viewer's Number.isSafeInteger).
  bool count(const json& v, const std::string& where, uint64_t* out) {
    constexpr double kLargestSafe = 9007199254740991.0;  // 2^53 - 1
    if (v.is_number_unsigned() && v.get<uint64_t>() <= uint64_t(kLargestSafe)) {
      *out = v.get<uint64_t>();
      return true;
    }
    if (v.is_number_float()) {
      const double d = v.get<double>();
      if (d >= 0 && d <= kLargestSafe && std::floor(d) == d) {
        *out = static_cast<uint64_t>(d);
        return true;
      }
    }
    return fail(where, "expected a count, got " + shown(v));
  }
  bool string(const json& v, const std::string& where, std::string* out) {
    if (!v.is_string()) return fail(where, "expected a string, got " + shown(v));
    *out = v.get<std::string>();
    return true;
  }
  /// An optional string: `fallback` when the key is absent.
  bool optional_string(const json& object, const char* key, const std::string& where,
                       const std::string& fallback, std::string* out) {
    const auto it = object.find(key);
    if (it == object.end()) {
      *out = fallback;
      return true;
    }
    return string(*it, where, out);
  }
  bool vec3(const json& v, const std::string& where, Vec3* out) {
    if (!v.is_array() || v.size() != 3) return fail(where, "expected [x, y, z]");
    double xyz[3];
    for (size_t i = 0; i < 3; ++i) {
      if (!number(v[i], where + "[" + std::to_string(i) + "]", &xyz[i])) return false;
    }
    *out = {float(xyz[0]), float(xyz[1]), float(xyz[2])};
    return true;
  }
  bool box(const json& v, const std::string& where, Aabb* out) {
    if (!v.is_object()) return fail(where, R"(expected {"min": [x, y, z], "max": [x, y, z]})");
    if (!vec3(member(v, "min"), where + ".min", &out->min)) return false;
    if (!vec3(member(v, "max"), where + ".max", &out->max)) return false;
    const float lo[3] = {out->min.x, out->min.y, out->min.z};
    const float hi[3] = {out->max.x, out->max.y, out->max.z};
    for (int i = 0; i < 3; ++i) {
      if (lo[i] > hi[i]) {
        const std::string k = std::to_string(i);
        return fail(where, "min[" + k + "] > max[" + k + "]");
      }
    }
    out->empty = false;
    return true;
  }

  /// `object[key]`, or null when absent (so a missing field reads as a wrong type).
  static const json& member(const json& object, const char* key) {
    static const json kNull;
    const auto it = object.find(key);
    return it == object.end() ? kNull : *it;
  }

 private:
  /// A value for a message: its JSON, at most 40 characters.
  static std::string shown(const json& v) {
    if (v.is_null()) return "nothing";
    std::string text = v.dump();
    if (text.size() > 40) text = text.substr(0, 37) + "...";
    return text;
  }

  const std::string& source_;
  Status status_;
};

/// A chunk file is named by its content hash, inside the package's c/ folder: nothing else is
/// accepted, so a manifest cannot make a reader open a file outside the package.
bool is_chunk_file(const std::string& name) {
  if (name.size() != 2 + 24 + 5 || name.rfind("c/", 0) != 0) return false;
  if (name.compare(26, 5, ".ostc") != 0) return false;
  return std::all_of(name.begin() + 2, name.begin() + 26,
                     [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
}

std::string at(const char* array, size_t i) {
  return std::string(array) + "[" + std::to_string(i) + "]";
}

bool parse_chunks(const json& in, Checker& check, Manifest* out) {
  std::set<std::string> files;
  for (size_t k = 0; k < in.size(); ++k) {
    const std::string where = at("chunks", k);
    ManifestChunk chunk;
    if (!check.object(in[k], where)) return false;
    if (!check.string(Checker::member(in[k], "file"), where + ".file", &chunk.file)) return false;
    if (!is_chunk_file(chunk.file)) {
      return check.fail(where + ".file", "expected \"c/<24 lower-case hex digits>.ostc\", got " +
                                             json(chunk.file).dump());
    }
    if (!files.insert(chunk.file).second) {
      return check.fail(where + ".file", json(chunk.file).dump() + " appears twice");
    }
    if (!check.count(Checker::member(in[k], "bytes"), where + ".bytes", &chunk.bytes)) {
      return false;
    }
    out->chunks.push_back(std::move(chunk));
  }
  return true;
}

bool parse_languages(const json& root, Checker& check, Manifest* out) {
  if (!root.contains("languages")) return true;
  const json& in = root["languages"];
  if (!in.is_array()) return check.fail("languages", "expected an array of language tags");
  if (in.size() > kMaxLanguages) {
    return check.fail("languages", std::to_string(in.size()) + " languages, at most " +
                                       std::to_string(kMaxLanguages));
  }
  for (size_t k = 0; k < in.size(); ++k) {
    std::string tag;
    if (!check.string(in[k], at("languages", k), &tag)) return false;
    if (!detail::is_language_tag(tag)) {
      return check.fail(at("languages", k),
                        "expected a language tag (\"en\", \"pt-BR\"), got " + json(tag).dump());
    }
    if (std::find(out->languages.begin(), out->languages.end(), tag) != out->languages.end()) {
      return check.fail(at("languages", k), json(tag).dump() + " appears twice");
    }
    out->languages.push_back(std::move(tag));
  }
  return true;
}

/// An optional "names" object {tag: name} of a group or part, its tags in the languages.
bool parse_names(const json& object, const std::string& where, Checker& check, const Manifest& m,
                 std::map<std::string, std::string>* out) {
  if (!object.contains("names")) return true;
  const json& in = object["names"];
  if (!in.is_object()) return check.fail(where + ".names", "expected an object {tag: name}");
  for (auto it = in.begin(); it != in.end(); ++it) {
    const std::string at_tag = where + ".names." + it.key();
    if (std::find(m.languages.begin(), m.languages.end(), it.key()) == m.languages.end()) {
      return check.fail(at_tag, json(it.key()).dump() + " is not in languages");
    }
    std::string name;
    if (!check.string(it.value(), at_tag, &name)) return false;
    out->emplace(it.key(), std::move(name));
  }
  return true;
}

bool parse_groups(const json& root, Checker& check, Manifest* out) {
  if (!root.contains("groups")) return true;
  const json& in = root["groups"];
  if (!in.is_array()) return check.fail("groups", "expected an array");
  if (in.size() > kMaxGroups) {
    return check.fail("groups",
                      std::to_string(in.size()) + " groups, at most " + std::to_string(kMaxGroups));
  }
  std::vector<int> depth;
  for (size_t i = 0; i < in.size(); ++i) {
    const std::string where = at("groups", i);
    if (!check.object(in[i], where)) return false;
    ManifestGroup group;
    if (!check.string(Checker::member(in[i], "name"), where + ".name", &group.name)) return false;
    if (group.name.empty()) return check.fail(where + ".name", "expected a non-empty name");
    if (in[i].contains("parent")) {
      uint64_t parent = 0;
      if (!check.count(in[i]["parent"], where + ".parent", &parent)) return false;
      if (parent >= i) {
        return check.fail(where + ".parent", "expected an earlier group's index (below " +
                                                 std::to_string(i) + "), got " +
                                                 std::to_string(parent));
      }
      group.parent = static_cast<int64_t>(parent);
    }
    depth.push_back(group.parent < 0 ? 1 : depth[size_t(group.parent)] + 1);
    if (depth.back() > kMaxGroupDepth) {
      return check.fail(where + ".parent",
                        "groups nested deeper than " + std::to_string(kMaxGroupDepth));
    }
    if (!parse_names(in[i], where, check, *out, &group.names)) return false;
    out->groups.push_back(std::move(group));
  }
  return true;
}

bool parse_parts(const json& in, Checker& check, Manifest* out) {
  for (size_t i = 0; i < in.size(); ++i) {
    const std::string where = at("parts", i);
    const json& p = in[i];
    if (!check.object(p, where)) return false;
    const json& id = Checker::member(p, "id");
    if (!id.is_number_unsigned() || id.get<uint64_t>() != i) {
      return check.fail(where + ".id", "expected " + std::to_string(i) + " (the index), got " +
                                           (id.is_null() ? std::string("nothing") : id.dump()));
    }
    ManifestPart part;
    if (!check.string(Checker::member(p, "name"), where + ".name", &part.name) ||
        !check.optional_string(p, "display_name", where + ".display_name", part.name,
                               &part.display_name) ||
        !check.optional_string(p, "group", where + ".group", "", &part.group) ||
        !check.optional_string(p, "source", where + ".source", "", &part.source) ||
        !check.count(Checker::member(p, "triangles"), where + ".triangles", &part.triangles) ||
        !check.count(Checker::member(p, "prototype"), where + ".prototype", &part.prototype)) {
      return false;
    }
    if (p.contains("color")) {
      if (!check.vec3(p["color"], where + ".color", &part.color)) return false;
      const float rgb[3] = {part.color.x, part.color.y, part.color.z};
      for (int k = 0; k < 3; ++k) {
        if (!(rgb[k] >= 0 && rgb[k] <= 1)) {
          return check.fail(where + ".color[" + std::to_string(k) + "]", "expected 0..1");
        }
      }
      part.has_color = true;
    }
    if (p.contains("path")) {
      uint64_t path = 0;
      if (!check.count(p["path"], where + ".path", &path)) return false;
      if (path >= out->groups.size()) {
        return check.fail(where + ".path", "no group " + std::to_string(path) +
                                               " (the package has " +
                                               std::to_string(out->groups.size()) + ")");
      }
      part.path = static_cast<int64_t>(path);
    }
    if (!parse_names(p, where, check, *out, &part.names) ||
        !check.optional_string(p, "system", where + ".system", "", &part.system)) {
      return false;
    }
    out->parts.push_back(std::move(part));
  }
  for (size_t i = 0; i < out->parts.size(); ++i) {
    const uint64_t prototype = out->parts[i].prototype;
    if (prototype >= out->parts.size()) {
      return check.fail(at("parts", i) + ".prototype", "no part " + std::to_string(prototype));
    }
  }
  return true;
}

/// The stream `v` names (chunk, offset, bytes), checked against the chunks.
bool parse_range(const json& v, const std::string& where, Checker& check, const Manifest& m,
                 uint64_t* chunk, uint64_t* offset, uint64_t* bytes) {
  if (!check.count(Checker::member(v, "chunk"), where + ".chunk", chunk)) return false;
  if (*chunk >= m.chunks.size()) {
    return check.fail(where + ".chunk", "no chunk " + std::to_string(*chunk) +
                                            " (the package has " +
                                            std::to_string(m.chunks.size()) + ")");
  }
  if (!check.count(Checker::member(v, "offset"), where + ".offset", offset) ||
      !check.count(Checker::member(v, "bytes"), where + ".bytes", bytes)) {
    return false;
  }
  const uint64_t chunk_bytes = m.chunks[*chunk].bytes;
  const std::string of_chunk =
      " the " + std::to_string(chunk_bytes) + " bytes of " + at("chunks", *chunk);
  if (*offset > chunk_bytes) {
    return check.fail(where + ".offset",
                      "byte " + std::to_string(*offset) + " lies beyond" + of_chunk);
  }
  if (*bytes == 0) return check.fail(where + ".bytes", "expected at least one byte");
  if (*bytes > chunk_bytes - *offset) {
    return check.fail(where + ".bytes", "bytes " + std::to_string(*offset) + "-" +
                                            std::to_string(*offset + *bytes) + " lie beyond" +
                                            of_chunk);
  }
  return true;
}

/// A component's coarser levels (docs/FORMAT.md "Levels of detail"), when it has any.
bool parse_levels(const json& c, const std::string& where, Checker& check, const Manifest& m,
                  ManifestComponent* component) {
  if (!c.contains("levels")) return true;
  const json& in = c["levels"];
  if (!in.is_array()) return check.fail(where + ".levels", "expected an array");
  for (size_t k = 0; k < in.size(); ++k) {
    const std::string at_level = where + ".levels[" + std::to_string(k) + "]";
    if (!check.object(in[k], at_level)) return false;
    ManifestLevel level;
    if (!parse_range(in[k], at_level, check, m, &level.chunk, &level.offset, &level.bytes) ||
        !check.count(Checker::member(in[k], "triangles"), at_level + ".triangles",
                     &level.triangles) ||
        !check.count(Checker::member(in[k], "vertices"), at_level + ".vertices",
                     &level.vertices) ||
        !check.number(Checker::member(in[k], "error"), at_level + ".error", &level.error)) {
      return false;
    }
    if (level.error < component->error_bound) {
      return check.fail(at_level + ".error", json(level.error).dump() +
                                                 " is below the component's error_bound " +
                                                 json(component->error_bound).dump());
    }
    component->levels.push_back(level);
  }
  for (size_t k = 0; k < component->levels.size(); ++k) {
    const uint64_t finer = k + 1 < component->levels.size() ? component->levels[k + 1].triangles
                                                            : component->triangles;
    if (component->levels[k].triangles >= finer) {
      return check.fail(where + ".levels[" + std::to_string(k) + "].triangles",
                        "expected fewer than the next finer level's " + std::to_string(finer));
    }
  }
  return true;
}

bool parse_components(const json& in, Checker& check, Manifest* out,
                      std::unordered_map<std::string, size_t>* index_of) {
  for (size_t i = 0; i < in.size(); ++i) {
    const std::string where = at("components", i);
    const json& c = in[i];
    if (!check.object(c, where)) return false;
    ManifestComponent component;
    if (!check.string(Checker::member(c, "id"), where + ".id", &component.id)) return false;
    if (index_of->count(component.id) != 0) {
      return check.fail(where + ".id", json(component.id).dump() + " appears twice");
    }
    if (!parse_range(c, where, check, *out, &component.chunk, &component.offset,
                     &component.bytes)) {
      return false;
    }
    if (!check.count(Checker::member(c, "triangles"), where + ".triangles", &component.triangles) ||
        !check.count(Checker::member(c, "vertices"), where + ".vertices", &component.vertices) ||
        !check.box(Checker::member(c, "bounds"), where + ".bounds", &component.bounds) ||
        !check.number(Checker::member(c, "error_bound"), where + ".error_bound",
                      &component.error_bound) ||
        !parse_levels(c, where, check, *out, &component)) {
      return false;
    }
    index_of->emplace(component.id, out->components.size());
    out->components.push_back(std::move(component));
  }
  return true;
}

bool parse_instances(const json& in, Checker& check,
                     const std::unordered_map<std::string, size_t>& index_of, Manifest* out) {
  for (size_t i = 0; i < in.size(); ++i) {
    const std::string where = at("instances", i);
    const json& v = in[i];
    if (!check.object(v, where)) return false;
    ManifestInstance instance;
    if (!check.count(Checker::member(v, "part"), where + ".part", &instance.part)) return false;
    if (instance.part >= out->parts.size()) {
      return check.fail(where + ".part", "no part " + std::to_string(instance.part));
    }
    if (!check.string(Checker::member(v, "component"), where + ".component", &instance.component)) {
      return false;
    }
    const auto component = index_of.find(instance.component);
    if (component == index_of.end()) {
      return check.fail(where + ".component", "no component " + json(instance.component).dump());
    }
    const json& matrix = Checker::member(v, "matrix");
    if (!matrix.is_array() || matrix.size() != 16) {
      return check.fail(where + ".matrix", "expected 16 numbers");
    }
    for (size_t k = 0; k < 16; ++k) {
      if (!check.number(matrix[k], where + ".matrix[" + std::to_string(k) + "]",
                        &instance.matrix[k])) {
        return false;
      }
    }
    // Singular in float is singular as drawn (and as written back: entries below a float's
    // smallest step are written as 0).
    Mat4 drawn;
    for (size_t k = 0; k < 16; ++k) drawn[k] = static_cast<float>(instance.matrix[k]);
    const double det = determinant3(instance.matrix);
    if (!(std::abs(det) > 0) || !(std::abs(determinant3(drawn)) > 0)) {
      return check.fail(where + ".matrix", "singular (determinant 0)");
    }
    // The winding on screen follows the matrix, whatever the "mirror" field says.
    instance.mirror = det < 0;
    instance.error_bound = out->components[component->second].error_bound;
    if (v.contains("error_bound") &&
        !check.number(v["error_bound"], where + ".error_bound", &instance.error_bound)) {
      return false;
    }
    out->instances.push_back(std::move(instance));
  }
  return true;
}

bool parse_stream_order(const json& in, Checker& check,
                        const std::unordered_map<std::string, size_t>& index_of, Manifest* out) {
  std::vector<bool> seen(out->components.size(), false);
  for (size_t i = 0; i < in.size(); ++i) {
    const std::string where = at("stream_order", i);
    const auto component =
        in[i].is_string() ? index_of.find(in[i].get<std::string>()) : index_of.end();
    if (component == index_of.end()) {
      return check.fail(where, "no component " + in[i].dump());
    }
    if (seen[component->second]) return check.fail(where, in[i].dump() + " appears twice");
    seen[component->second] = true;
    out->stream_order.push_back(in[i].get<std::string>());
  }
  std::string missing;
  size_t missing_count = 0;
  for (size_t c = 0; c < seen.size(); ++c) {
    if (seen[c]) continue;
    if (++missing_count <= 5) missing += (missing.empty() ? "" : ", ") + out->components[c].id;
  }
  if (missing_count > 5) missing += ", ...";
  return missing_count == 0 || check.fail("stream_order", "misses " + missing);
}

}  // namespace

Result<Manifest> parse_manifest(const uint8_t* data, size_t size, const std::string& source) {
  Checker check(source);
  const json in = json::parse(data, data + size, nullptr, /*allow_exceptions=*/false);
  if (in.is_discarded()) return error(ErrorCode::kInvalidData, source, "top level: not JSON");
  if (!in.is_object()) {
    check.fail("top level", "expected a JSON object");
    return check.status();
  }
  const json& format = Checker::member(in, "format");
  if (!format.is_string() || format.get<std::string>() != "osteon-package") {
    check.fail("format", "expected \"osteon-package\"");
    return check.status();
  }
  const json& version = Checker::member(in, "version");
  if (!version.is_number_integer() ||
      (version.get<int64_t>() != kManifestVersion && version.get<int64_t>() != 2)) {
    check.fail("version",
               "osteon reads versions 2 and " + std::to_string(kManifestVersion) +
                   ", the package is version " + version.dump(),
               ErrorCode::kUnsupported);
    return check.status();
  }
  Manifest manifest;
  manifest.stream_version = 0;  // not said
  if (in.contains("stream_version")) {
    const json& streams = in["stream_version"];
    if (!streams.is_number_integer() || streams.get<int64_t>() < 1 ||
        streams.get<int64_t>() > kStreamVersion) {
      check.fail("stream_version",
                 "osteon decodes stream versions 1 to " + std::to_string(kStreamVersion) +
                     ", the package's are version " + streams.dump(),
                 ErrorCode::kUnsupported);
      return check.status();
    }
    manifest.stream_version = static_cast<int>(streams.get<int64_t>());
  }
  std::string unit;
  if (!check.string(Checker::member(in, "unit"), "unit", &unit)) return check.status();
  const bool known = unit == "mm" || unit == "cm" || unit == "m" || unit == "in";
  if (known) parse_unit(unit, &manifest.unit);
  if (!known && unit != "unknown") {
    check.fail("unit", "expected one of mm, cm, m, in, unknown, got " + json(unit).dump());
    return check.status();
  }
  if (!check.box(Checker::member(in, "bounds"), "bounds", &manifest.bounds)) {
    return check.status();
  }
  if (in.contains("view")) {
    const json& view = in["view"];
    if (!view.is_object()) {
      check.fail("view", R"(expected {"up": [x, y, z], "eye": [x, y, z]})");
      return check.status();
    }
    if (!check.vec3(Checker::member(view, "up"), "view.up", &manifest.view_up) ||
        !check.vec3(Checker::member(view, "eye"), "view.eye", &manifest.view_eye)) {
      return check.status();
    }
    const Vec3d up = to_double(manifest.view_up), eye = to_double(manifest.view_eye);
    if (!(length(cross(up, eye)) > 1e-6 * length(up) * length(eye))) {
      check.fail("view", "up and eye must be non-zero and not parallel");
      return check.status();
    }
    manifest.has_view = true;
  }
  for (const char* key : {"chunks", "parts", "components", "instances", "stream_order"}) {
    if (!Checker::member(in, key).is_array()) {
      check.fail(key, "expected an array");
      return check.status();
    }
  }
  std::unordered_map<std::string, size_t> index_of;
  const bool ok = parse_languages(in, check, &manifest) && parse_groups(in, check, &manifest) &&
                  parse_chunks(in["chunks"], check, &manifest) &&
                  parse_parts(in["parts"], check, &manifest) &&
                  parse_components(in["components"], check, &manifest, &index_of) &&
                  parse_instances(in["instances"], check, index_of, &manifest) &&
                  parse_stream_order(in["stream_order"], check, index_of, &manifest);
  if (!ok) return check.status();
  return manifest;
}

}  // namespace osteon
