// SPDX-License-Identifier: Apache-2.0
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
        const std::string file = text_of(entry, {"filename", "file", "stem", "name"});
        if (file.empty()) continue;
        names[stem_of(file)] = {text_of(entry, {"label", "display_name", "name"}),
                                text_of(entry, {"group"})};
      }
    } else {
      for (auto it = j.begin(); it != j.end(); ++it) {
        if (it->is_string()) {
          names[stem_of(it.key())] = {it->get<std::string>(), {}};
        } else if (it->is_object()) {
          names[stem_of(it.key())] = {text_of(*it, {"display_name", "label", "name"}),
                                      text_of(*it, {"group"})};
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
      if (f[0].rfind("file", 0) == 0 || f[0].rfind("stem", 0) == 0) continue;
    }
    if (f.size() < 2) return error(ErrorCode::kInvalidData, path, "a CSV line needs 2 fields");
    names[stem_of(f[0])] = {f[1], f.size() > 2 ? f[2] : std::string()};
  }
  return names;
}

}  // namespace osteon::detail
