// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "osteon/io.hpp"
#include "osteon/package.hpp"
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

/// Splits "Skeleton / Lower limb / Right" at its " / " separators.
std::vector<GroupName> split_path(const std::string& text) {
  std::vector<GroupName> path;
  if (text.empty()) return path;
  size_t start = 0;
  while (true) {
    const size_t bar = text.find(" / ", start);
    path.push_back(
        {text.substr(start, bar == std::string::npos ? std::string::npos : bar - start), {}});
    if (bar == std::string::npos) break;
    start = bar + 3;
  }
  return path;
}

/// A JSON "names" object {tag: name} of an entry or a path group.
Status json_names(const nlohmann::json& entry, const std::string& path, const std::string& key,
                  std::map<std::string, std::string>* out) {
  const auto it = entry.find("names");
  if (it == entry.end()) return {};
  if (!it->is_object()) {
    return error(ErrorCode::kInvalidData, path, key + ": names: expected an object {tag: name}");
  }
  for (auto n = it->begin(); n != it->end(); ++n) {
    if (!n->is_string()) {
      return error(ErrorCode::kInvalidData, path,
                   key + ": names." + n.key() + ": expected a string");
    }
    (*out)[n.key()] = n->get<std::string>();
  }
  return {};
}

/// A JSON "path": an array of group names (or {"name", "names"} objects), outermost first, or
/// one string "Skeleton / Lower limb".
Status json_path(const nlohmann::json& entry, const std::string& path, const std::string& key,
                 DisplayName* name) {
  const auto it = entry.find("path");
  if (it == entry.end()) return {};
  if ((it->is_string() && it->get<std::string>().empty()) || (it->is_array() && it->empty())) {
    return error(ErrorCode::kInvalidData, path,
                 key + ": path: empty (leave it out for a part in no group)");
  }
  if (it->is_string()) {
    name->path = split_path(it->get<std::string>());
    return {};
  }
  if (!it->is_array()) {
    return error(ErrorCode::kInvalidData, path,
                 key + ": path: expected an array of group names, outermost first");
  }
  for (size_t k = 0; k < it->size(); ++k) {
    const nlohmann::json& g = (*it)[k];
    const std::string where = key + ": path[" + std::to_string(k) + "]";
    GroupName group;
    if (g.is_string()) {
      group.name = g.get<std::string>();
    } else if (g.is_object() && g.contains("name") && g["name"].is_string()) {
      group.name = g["name"].get<std::string>();
      OSTEON_RETURN_IF_ERROR(json_names(g, path, where, &group.names));
    } else {
      return error(ErrorCode::kInvalidData, path,
                   where + ": expected a group name or {\"name\": ..., \"names\": {...}}");
    }
    name->path.push_back(std::move(group));
  }
  return {};
}

/// The checks every form shares: path groups named and at most kMaxGroupDepth deep, names only
/// in the listed languages (when the file lists them), languages well-formed and unique. Without
/// a list, the languages are "und" (undetermined: the display names') and every tag used, sorted.
Status check_names(const std::string& path, bool listed, Names* names) {
  for (size_t k = 0; k < names->languages.size(); ++k) {
    const std::string& tag = names->languages[k];
    if (!is_language_tag(tag)) {
      return error(ErrorCode::kInvalidData, path,
                   "languages[" + std::to_string(k) +
                       "]: expected a language tag (\"en\", \"pt-BR\"), got \"" + tag + "\"");
    }
    if (std::find(names->languages.begin(), names->languages.begin() + k, tag) !=
        names->languages.begin() + k) {
      return error(ErrorCode::kInvalidData, path, "languages: \"" + tag + "\" appears twice");
    }
  }
  if (names->languages.size() > kMaxLanguages) {
    return error(ErrorCode::kInvalidData, path,
                 "languages: more than " + std::to_string(kMaxLanguages));
  }
  std::set<std::string> used;
  const auto check_tags = [&](const std::map<std::string, std::string>& tags,
                              const std::string& where) -> Status {
    for (const auto& [tag, text] : tags) {
      if (listed && std::find(names->languages.begin(), names->languages.end(), tag) ==
                        names->languages.end()) {
        return error(ErrorCode::kInvalidData, path,
                     where + ": names." + tag + ": \"" + tag + "\" is not in languages");
      }
      if (!listed && !is_language_tag(tag)) {
        return error(ErrorCode::kInvalidData, path,
                     where + ": names." + tag + ": expected a language tag (\"en\", \"pt-BR\")");
      }
      used.insert(tag);
    }
    return {};
  };
  for (const auto& [key, entry] : names->parts) {
    OSTEON_RETURN_IF_ERROR(check_tags(entry.names, key));
    if (entry.path.size() > size_t(kMaxGroupDepth)) {
      return error(ErrorCode::kInvalidData, path,
                   key + ": path: " + std::to_string(entry.path.size()) + " groups, at most " +
                       std::to_string(kMaxGroupDepth));
    }
    for (size_t k = 0; k < entry.path.size(); ++k) {
      const std::string where = key + ": path[" + std::to_string(k) + "]";
      if (entry.path[k].name.empty()) {
        return error(ErrorCode::kInvalidData, path, where + ": an empty group name");
      }
      for (size_t j = 0; j < k; ++j) {
        if (entry.path[j].name == entry.path[k].name) {
          return error(ErrorCode::kInvalidData, path,
                       where + ": \"" + entry.path[k].name + "\" is inside itself (path[" +
                           std::to_string(j) + "]): a cycle in the hierarchy");
        }
      }
      OSTEON_RETURN_IF_ERROR(check_tags(entry.path[k].names, where));
    }
  }
  // Every distinct path prefix becomes a group: at most kMaxGroups of them, as the manifest holds.
  std::set<std::vector<std::string>> prefixes;
  for (const auto& [key, entry] : names->parts) {
    std::vector<std::string> prefix;
    for (const GroupName& g : entry.path) {
      prefix.push_back(g.name);
      prefixes.insert(prefix);
    }
    if (prefixes.size() > kMaxGroups) {
      return error(ErrorCode::kInvalidData, path,
                   key + ": path: more than " + std::to_string(kMaxGroups) + " groups in all");
    }
  }
  if (!listed && !used.empty()) {
    used.erase("und");
    names->languages = {"und"};
    names->languages.insert(names->languages.end(), used.begin(), used.end());
  }
  return {};
}

/// A CSV header's column for `field`: its index, or `fallback` when it is not named.
size_t column(const std::vector<std::string>& header, std::initializer_list<const char*> fields,
              size_t fallback) {
  for (size_t c = 0; c < header.size(); ++c) {
    for (const char* field : fields) {
      if (header[c] == field) return c;
    }
  }
  return fallback;
}

}  // namespace

Result<Names> read_names(const std::string& path) {
  OSTEON_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, read_file(path));
  return parse_names(bytes, path);
}

Result<Names> parse_names(const std::vector<uint8_t>& bytes, const std::string& source) {
  const std::string& path = source;  // messages open with it
  const std::string text(bytes.begin(), bytes.end());
  Names out;
  std::map<std::string, DisplayName>& names = out.parts;
  // The file's own order ranks its paths' groups (after derived regions: DisplayName::rank).
  int32_t order = kNamesFileRank;
  bool listed = false;
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
    // {"languages": [...], "parts": [entries]}: an entry of the object form is a string or an
    // object, never an array, so "parts" holding an array is this form.
    if (j.is_object() && j.contains("parts") && j["parts"].is_array()) {
      if (j.contains("languages")) {
        const nlohmann::json& tags = j["languages"];
        if (!tags.is_array() || !std::all_of(tags.begin(), tags.end(), [](const nlohmann::json& t) {
              return t.is_string();
            })) {
          return error(ErrorCode::kInvalidData, path,
                       "languages: expected an array of language tags");
        }
        for (const nlohmann::json& t : tags) out.languages.push_back(t.get<std::string>());
        listed = true;
      }
      nlohmann::json entries = std::move(j["parts"]);
      j = std::move(entries);
    }
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
        OSTEON_RETURN_IF_ERROR(json_path(entry, path, file, &name));
        OSTEON_RETURN_IF_ERROR(json_names(entry, path, file, &name.names));
        name.system = text_of(entry, {"system"});
        name.rank = order++;
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
          OSTEON_RETURN_IF_ERROR(json_path(*it, path, it.key(), &name));
          OSTEON_RETURN_IF_ERROR(json_names(*it, path, it.key(), &name.names));
          name.system = text_of(*it, {"system"});
          name.rank = order++;
          names[stem_of(it.key())] = std::move(name);
        }
      }
    }
    OSTEON_RETURN_IF_ERROR(check_names(path, listed, &out));
    return out;
  }
  std::istringstream lines(text);
  std::string line;
  bool first_line = true;
  // Columns: positional (stem, display_name, group, color), or named by a header, which may add
  // "path" (groups joined by " / "), "system" and "name:<tag>" columns (the part's name in that
  // language); "display_name:<tag>" names the display names' language.
  std::vector<std::string> header;
  size_t c_name = 1, c_group = 2, c_color = 3, c_path = SIZE_MAX, c_system = SIZE_MAX;
  std::vector<std::pair<size_t, std::string>> c_names;
  while (std::getline(lines, line)) {
    if (line.empty() || line == "\r") continue;
    std::vector<std::string> f = csv_fields(line);
    if (first_line) {
      first_line = false;
      if (f[0].rfind("file", 0) == 0 || f[0].rfind("stem", 0) == 0 || f[0].rfind("value", 0) == 0) {
        header = f;
        std::string display_language;
        for (size_t c = 1; c < header.size(); ++c) {
          for (const char* prefix : {"display_name:", "label:"}) {
            if (header[c].rfind(prefix, 0) == 0) {
              display_language = header[c].substr(std::strlen(prefix));
              header[c] = "display_name";
            }
          }
        }
        // Columns by their header names; a classic position (display name, group, colour) that
        // the header leaves unnamed, or names otherwise, keeps its positional meaning.
        const auto known = [](const std::string& h) {
          for (const char* field :
               {"display_name", "label", "name", "group", "color", "colour", "path", "system"}) {
            if (h == field) return true;
          }
          return h.rfind("name:", 0) == 0;
        };
        const auto positional = [&](size_t c) {
          return c >= header.size() || !known(header[c]) ? c : SIZE_MAX;
        };
        for (size_t c = 1; c < header.size(); ++c) {
          if (!known(header[c])) {
            return error(ErrorCode::kInvalidData, path,
                         "header: column " + std::to_string(c + 1) + " (\"" + header[c] +
                             "\"): unknown; expected display_name, name:<tag>, group, color, "
                             "path or system");
          }
        }
        c_name = column(header, {"display_name", "label", "name"}, positional(1));
        c_group = column(header, {"group"}, positional(2));
        c_color = column(header, {"color", "colour"}, positional(3));
        c_path = column(header, {"path"}, SIZE_MAX);
        c_system = column(header, {"system"}, SIZE_MAX);
        for (size_t c = 0; c < header.size(); ++c) {
          if (header[c].rfind("name:", 0) == 0) c_names.emplace_back(c, header[c].substr(5));
        }
        if (!display_language.empty() || !c_names.empty()) {
          out.languages.push_back(display_language.empty() ? "und" : display_language);
          for (const auto& [c, tag] : c_names) out.languages.push_back(tag);
          listed = true;
        }
        continue;
      }
    }
    if (f.size() < 2) return error(ErrorCode::kInvalidData, path, "a CSV line needs 2 fields");
    const auto field = [&](size_t c) { return c < f.size() ? f[c] : std::string(); };
    DisplayName name{field(c_name), field(c_group)};
    const std::string color = field(c_color);
    if (!color.empty()) {
      if (!parse_color(color, &name.color)) {
        return error(ErrorCode::kInvalidData, path,
                     f[0] + ": color: expected \"#rrggbb\" or three numbers 0..1");
      }
      name.has_color = true;
    }
    if (c_path != SIZE_MAX && field(c_path).empty()) {
      return error(ErrorCode::kInvalidData, path,
                   f[0] + ": path: empty (with a path column, every row names its groups)");
    }
    name.path = split_path(field(c_path));
    name.system = field(c_system);
    for (const auto& [c, tag] : c_names) {
      if (!field(c).empty()) name.names[tag] = field(c);
    }
    name.rank = order++;
    names[stem_of(f[0])] = std::move(name);
  }
  OSTEON_RETURN_IF_ERROR(check_names(path, listed, &out));
  return out;
}

const DisplayName* find_display_name(const Names& names, const Mesh& part) {
  auto it = names.parts.find(stem_of(part.name));
  if (it == names.parts.end() && part.label > 0) it = names.parts.find(std::to_string(part.label));
  return it == names.parts.end() ? nullptr : &it->second;
}

DisplayName* find_display_name(Names& names, const Mesh& part) {
  return const_cast<DisplayName*>(find_display_name(std::as_const(names), part));
}

}  // namespace osteon::detail
