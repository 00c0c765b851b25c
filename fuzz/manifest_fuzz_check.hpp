// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "osteon/package.hpp"

// What fuzz/manifest_fuzzer.cpp checks of one input, shared with tests/fuzz_corpus_test.cpp so
// the corpus replay asks exactly what the fuzzer asks: parse_manifest on the bytes; an error must
// name `source`; a Manifest must keep parse_manifest's promises (indices, byte ranges, boxes,
// matrices, levels, stream_order) and write back: write_manifest's text parses again, and writing
// that gives the same text but for the error bounds. Known approximation: the bounds are left out
// of that comparison because write_manifest rounds them up to a float each time it writes them,
// so they may grow by a float step a round trip.

namespace osteon::fuzz {

/// What one input gave: whether it parsed, and the first broken promise ("" when none).
struct ManifestFuzzOutcome {
  bool parsed = false;
  std::string broken;
};

namespace manifest_check {

inline bool finite(const Vec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

inline bool box_ok(const Aabb& box) {
  return finite(box.min) && finite(box.max) && box.min.x <= box.max.x && box.min.y <= box.max.y &&
         box.min.z <= box.max.z;
}

inline bool range_ok(const Manifest& m, uint64_t chunk, uint64_t offset, uint64_t bytes) {
  return chunk < m.chunks.size() && bytes > 0 && offset <= m.chunks[chunk].bytes &&
         bytes <= m.chunks[chunk].bytes - offset;
}

/// The first promise `m` breaks, naming the field; "" when it keeps them all.
inline std::string broken(const Manifest& m) {
  if (!box_ok(m.bounds)) return "bad bounds";
  if (m.has_view && !(finite(m.view_up) && finite(m.view_eye))) return "non-finite view";
  const auto names_ok = [&](const std::map<std::string, std::string>& names) {
    for (const auto& [tag, text] : names) {
      if (std::find(m.languages.begin(), m.languages.end(), tag) == m.languages.end()) return false;
    }
    return true;
  };
  if (m.languages.size() > kMaxLanguages) return "too many languages";
  if (std::set<std::string>(m.languages.begin(), m.languages.end()).size() != m.languages.size())
    return "a language twice";
  if (m.groups.size() > kMaxGroups) return "too many groups";
  std::vector<int> depth;
  for (size_t g = 0; g < m.groups.size(); ++g) {
    const ManifestGroup& group = m.groups[g];
    if (group.name.empty()) return "empty group name";
    if (group.parent >= int64_t(g) || group.parent < -1)
      return "group parent not earlier: " + group.name;
    depth.push_back(group.parent < 0 ? 1 : depth[size_t(group.parent)] + 1);
    if (depth.back() > kMaxGroupDepth) return "groups too deep: " + group.name;
    if (!names_ok(group.names)) return "group name in an unlisted language: " + group.name;
  }
  for (const ManifestPart& part : m.parts) {
    if (part.prototype >= m.parts.size()) return "prototype out of range: " + part.name;
    if (part.path < -1 || part.path >= int64_t(m.groups.size()))
      return "path out of range: " + part.name;
    if (!names_ok(part.names)) return "part name in an unlisted language: " + part.name;
    const Vec3& c = part.color;
    if (part.has_color && !(c.x >= 0 && c.x <= 1 && c.y >= 0 && c.y <= 1 && c.z >= 0 && c.z <= 1))
      return "color out of 0..1: " + part.name;
  }
  std::set<std::string> ids;
  for (const ManifestComponent& c : m.components) {
    if (!ids.insert(c.id).second) return "duplicate component id " + c.id;
    if (!range_ok(m, c.chunk, c.offset, c.bytes)) return "bad byte range: " + c.id;
    if (!box_ok(c.bounds)) return "bad component bounds: " + c.id;
    if (!std::isfinite(c.error_bound)) return "non-finite error_bound: " + c.id;
    for (size_t k = 0; k < c.levels.size(); ++k) {
      const ManifestLevel& level = c.levels[k];
      if (!range_ok(m, level.chunk, level.offset, level.bytes))
        return "bad level byte range: " + c.id;
      if (!(std::isfinite(level.error) && level.error >= c.error_bound))
        return "level error not finite or below the bound: " + c.id;
      const uint64_t finer = k + 1 < c.levels.size() ? c.levels[k + 1].triangles : c.triangles;
      if (level.triangles >= finer) return "level triangles not fewer: " + c.id;
    }
  }
  for (const ManifestInstance& instance : m.instances) {
    if (instance.part >= m.parts.size()) return "instance part out of range";
    if (ids.count(instance.component) == 0)
      return "instance of an unknown component " + instance.component;
    for (double v : instance.matrix) {
      if (!std::isfinite(v)) return "non-finite matrix entry: " + instance.component;
    }
    const double det = determinant3(instance.matrix);
    if (!(std::abs(det) > 0)) return "singular matrix: " + instance.component;
    if (instance.mirror != (det < 0)) return "mirror disagrees: " + instance.component;
    if (!std::isfinite(instance.error_bound))
      return "non-finite instance error_bound: " + instance.component;
  }
  std::set<std::string> ordered(m.stream_order.begin(), m.stream_order.end());
  if (m.stream_order.size() != m.components.size() || ordered != ids)
    return "stream_order is not every component once";
  return "";
}

/// write_manifest's text, parsed, without the error bounds (components', levels', instances').
inline nlohmann::json without_error_bounds(const std::string& text) {
  nlohmann::json m = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (!m.is_object()) return m;
  for (nlohmann::json& c : m["components"]) {
    c.erase("error_bound");
    if (c.contains("levels")) {
      for (nlohmann::json& level : c["levels"]) level.erase("error");
    }
  }
  for (nlohmann::json& i : m["instances"]) i.erase("error_bound");
  return m;
}

}  // namespace manifest_check

/// Runs one input as the fuzzer does; `source` names it in parse_manifest's messages.
inline ManifestFuzzOutcome manifest_fuzz_one(const uint8_t* data, size_t size,
                                             const std::string& source) {
  ManifestFuzzOutcome out;
  Result<Manifest> manifest = parse_manifest(data, size, source);
  if (!manifest.ok()) {
    const std::string& message = manifest.status().message();
    if (message.rfind(source + ": ", 0) != 0 || message.size() <= source.size() + 2)
      out.broken = "message without source: " + message;
    return out;
  }
  out.parsed = true;
  out.broken = manifest_check::broken(*manifest);
  if (!out.broken.empty()) return out;
  const std::string written = write_manifest(*manifest);
  Result<Manifest> again =
      parse_manifest(reinterpret_cast<const uint8_t*>(written.data()), written.size(), source);
  if (!again.ok()) {
    out.broken = "written manifest does not parse: " + again.status().message();
    return out;
  }
  out.broken = manifest_check::broken(*again);
  if (!out.broken.empty()) {
    out.broken = "written manifest: " + out.broken;
  } else if (manifest_check::without_error_bounds(write_manifest(*again)) !=
             manifest_check::without_error_bounds(written)) {
    out.broken = "written manifest is not a fixed point: " + written;
  }
  return out;
}

}  // namespace osteon::fuzz
