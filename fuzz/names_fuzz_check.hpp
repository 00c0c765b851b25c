// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "osteon/package.hpp"
#include "package/package_internal.hpp"

// What fuzz/names_fuzzer.cpp checks of one input, shared with tests/fuzz_corpus_test.cpp so the
// corpus replay asks exactly what the fuzzer asks. The bytes go to parse_names as a names file
// (JSON or CSV, as read_names reads it); an error must name `source`; a Names must keep what
// read_names promises: every path group named, a path at most kMaxGroupDepth deep and no group
// twice in one path, at most kMaxGroups distinct path prefixes in all, languages well-formed,
// unique and at most kMaxLanguages, every name in a listed language, colours in 0..1.

namespace osteon::fuzz {

/// What one input gave: whether it parsed, and the first broken promise ("" when none).
struct NamesFuzzOutcome {
  bool parsed = false;
  std::string broken;
};

namespace names_check {

/// The first promise `names` breaks, naming the entry; "" when it keeps them all.
inline std::string broken(const detail::Names& names) {
  const std::vector<std::string>& languages = names.languages;
  if (languages.size() > kMaxLanguages) return "too many languages";
  if (std::set<std::string>(languages.begin(), languages.end()).size() != languages.size())
    return "a language twice";
  for (const std::string& tag : languages) {
    if (!detail::is_language_tag(tag)) return "not a language tag: " + tag;
  }
  const auto listed = [&](const std::map<std::string, std::string>& tags) {
    for (const auto& [tag, text] : tags) {
      if (std::find(languages.begin(), languages.end(), tag) == languages.end()) return false;
    }
    return true;
  };
  std::set<std::vector<std::string>> prefixes;
  for (const auto& [key, entry] : names.parts) {
    if (!listed(entry.names)) return "a name in an unlisted language: " + key;
    if (entry.path.size() > size_t(kMaxGroupDepth)) return "path too deep: " + key;
    std::vector<std::string> prefix;
    for (const detail::GroupName& group : entry.path) {
      if (group.name.empty()) return "an empty group name: " + key;
      if (std::find(prefix.begin(), prefix.end(), group.name) != prefix.end())
        return "a group twice in one path: " + key + ": " + group.name;
      if (!listed(group.names)) return "a group name in an unlisted language: " + key;
      prefix.push_back(group.name);
      prefixes.insert(prefix);
    }
    const Vec3& c = entry.color;
    if (entry.has_color && !(c.x >= 0 && c.x <= 1 && c.y >= 0 && c.y <= 1 && c.z >= 0 && c.z <= 1))
      return "color out of 0..1: " + key;
  }
  if (prefixes.size() > kMaxGroups) return "too many groups";
  return "";
}

}  // namespace names_check

/// Runs one input as the fuzzer does; `source` names it in parse_names's messages.
inline NamesFuzzOutcome names_fuzz_one(const uint8_t* data, size_t size,
                                       const std::string& source) {
  NamesFuzzOutcome out;
  Result<detail::Names> names =
      detail::parse_names(std::vector<uint8_t>(data, data + size), source);
  if (!names.ok()) {
    const std::string& message = names.status().message();
    if (message.rfind(source + ": ", 0) != 0 || message.size() <= source.size() + 2)
      out.broken = "message without source: " + message;
    return out;
  }
  out.parsed = true;
  out.broken = names_check::broken(*names);
  return out;
}

}  // namespace osteon::fuzz
