// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <charconv>
#include <initializer_list>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "osteon/io.hpp"
#include "package/package_internal.hpp"

// Names files (docs/FORMAT.md "Names file"): display names and groups for parts, keyed by the
// part's file stem, as BodyParts3D's meta.json, a JSON object or a CSV gives them.

namespace osteon::detail {

std::string stem_of(const std::string& name) {
  std::string s = name;
  const size_t slash = s.find_last_of("/\\");
  if (slash != std::string::npos) s = s.substr(slash + 1);
  const size_t dot = s.find_last_of('.');
  if (dot != std::string::npos && dot > 0) s = s.substr(0, dot);
  return s;
}

namespace {

/// Splits one CSV line (fields may be double-quoted, "" an escaped quote).
std::vector<std::string> csv_fields(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        fields.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        fields.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      fields.emplace_back();
    } else if (c != '\r') {
      fields.back() += c;
    }
  }
  return fields;
}

/// A colour: "#rrggbb", or three numbers 0..1 separated by spaces. False when it is neither.
bool parse_color(const std::string& text, Vec3* out) {
  if (text.size() == 7 && text[0] == '#') {
    float rgb[3];
    for (int k = 0; k < 3; ++k) {
      unsigned value = 0;
      const auto [end, ec] =
          std::from_chars(text.data() + 1 + 2 * k, text.data() + 3 + 2 * k, value, 16);
      if (ec != std::errc() || end != text.data() + 3 + 2 * k) return false;
      rgb[k] = float(value) / 255.0f;
    }
    *out = {rgb[0], rgb[1], rgb[2]};
    return true;
  }
  std::istringstream in(text);
  float r = -1, g = -1, b = -1;
  if (!(in >> r >> g >> b)) return false;
  std::string rest;
  if (in >> rest) return false;
  for (float v : {r, g, b}) {
    if (!(v >= 0 && v <= 1)) return false;
  }
  *out = {r, g, b};
  return true;
}

/// The colour of a JSON entry: "color" as "#rrggbb", "r g b" or [r, g, b] (0..1).
Status json_color(const nlohmann::json& entry, const std::string& path, const std::string& key,
                  DisplayName* name) {
  const auto it = entry.find("color");
  if (it == entry.end()) return {};
  std::string text;
  if (it->is_string()) {
    text = it->get<std::string>();
  } else if (it->is_array() && it->size() == 3 &&
             std::all_of(it->begin(), it->end(),
                         [](const nlohmann::json& v) { return v.is_number(); })) {
    text = std::to_string((*it)[0].get<double>()) + " " + std::to_string((*it)[1].get<double>()) +
           " " + std::to_string((*it)[2].get<double>());
  }
  if (!parse_color(text, &name->color)) {
    return error(ErrorCode::kInvalidData, path,
                 key + ": color: expected \"#rrggbb\" or three numbers 0..1");
  }
  name->has_color = true;
  return {};
}

}  // namespace

Result<std::map<std::string, DisplayName>> read_names(const std::string& path) {
  OSTEON_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, read_file(path));
  const std::string text(bytes.begin(), bytes.end());
  std::map<std::string, DisplayName> names;
  size_t first = text.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && (text[first] == '[' || text[first] == '{')) {
    nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
    if (j.is_discarded()) return error(ErrorCode::kInvalidData, path, "not valid JSON");
    auto text_of = [](const nlohmann::json& o, std::initializer_list<const char*> keys) {
      for (const char* key : keys) {
        auto it = o.find(key);
        if (it != o.end() && it->is_string()) return it->get<std::string>();
      }
      return std::string();
    };
    if (j.is_array()) {
      for (const nlohmann::json& entry : j) {
        if (!entry.is_object()) continue;
        std::string file = text_of(entry, {"filename", "file", "stem", "name"});
        if (file.empty() && entry.contains("value") && entry["value"].is_number_unsigned()) {
          file = std::to_string(entry["value"].get<uint64_t>());
        }
        if (file.empty()) continue;
        DisplayName name{text_of(entry, {"label", "display_name", "name"}),
                         text_of(entry, {"group"})};
        OSTEON_RETURN_IF_ERROR(json_color(entry, path, file, &name));
        names[stem_of(file)] = std::move(name);
      }
    } else {
      for (auto it = j.begin(); it != j.end(); ++it) {
        if (it->is_string()) {
          names[stem_of(it.key())] = {it->get<std::string>(), {}};
        } else if (it->is_object()) {
          DisplayName name{text_of(*it, {"display_name", "label", "name"}),
                           text_of(*it, {"group"})};
          OSTEON_RETURN_IF_ERROR(json_color(*it, path, it.key(), &name));
          names[stem_of(it.key())] = std::move(name);
        }
      }
    }
    return names;
  }
  std::istringstream lines(text);
  std::string line;
  bool first_line = true;
  while (std::getline(lines, line)) {
    if (line.empty() || line == "\r") continue;
    std::vector<std::string> f = csv_fields(line);
    if (first_line) {
      first_line = false;
      if (f[0].rfind("file", 0) == 0 || f[0].rfind("stem", 0) == 0 || f[0].rfind("value", 0) == 0) {
        continue;
      }
    }
    if (f.size() < 2) return error(ErrorCode::kInvalidData, path, "a CSV line needs 2 fields");
    DisplayName name{f[1], f.size() > 2 ? f[2] : std::string()};
    if (f.size() > 3 && !f[3].empty()) {
      if (!parse_color(f[3], &name.color)) {
        return error(ErrorCode::kInvalidData, path,
                     f[0] + ": color: expected \"#rrggbb\" or three numbers 0..1");
      }
      name.has_color = true;
    }
    names[stem_of(f[0])] = std::move(name);
  }
  return names;
}

}  // namespace osteon::detail
