// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <cctype>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include "osteon/io.hpp"
#include "package/package_internal.hpp"

// Regions from BodyParts3D's ontology tables: the "conventional part of" tree (FMA20394 human
// body -> FMA7184 lower limb -> ... -> FMA24474 right femur), the "is a" element parts (which FMA
// concepts each BodyParts3D file FJ<n> is an element of) and the English names. A bone's region
// is the region of kRegionRules whose concepts lie nearest above it: the tables hold more than
// one parent per concept, and some of those parents are loose (toe phalanges are in "set of
// phalanges", itself in "skeleton of upper limb"), so the nearest ancestor decides, not any.

namespace osteon::detail {

namespace {

/// The ontology graph: concepts by id, their parents, and their ids by English name.
struct Ontology {
  std::unordered_map<std::string, uint32_t> index;  // "FMA24474" or "FJ3171" -> node
  std::vector<std::string> names;                   // English names, "" when unknown
  std::vector<std::vector<uint32_t>> parents;
  std::unordered_map<std::string, std::vector<uint32_t>> by_name;

  uint32_t node(const std::string& id) {
    const auto [it, added] = index.emplace(id, uint32_t(names.size()));
    if (added) {
      names.emplace_back();
      parents.emplace_back();
    }
    return it->second;
  }
  void name(uint32_t n, const std::string& text) {
    if (names[n].empty() && !text.empty()) names[n] = text;
  }
};

/// Parses one of the tables (`text`, the contents of the file `path`): tab-separated lines of at
/// least `fields` fields, the first a header. Calls `row` with each line's fields.
template <typename Row>
Status parse_table(const std::string& text, const std::string& path, size_t fields, Row row) {
  size_t start = 0;
  size_t line = 0;
  std::vector<std::string> f;
  while (start < text.size()) {
    size_t end = start;
    while (end < text.size() && text[end] != '\n') ++end;
    ++line;
    f.assign(1, std::string());
    for (size_t i = start; i < end; ++i) {
      const char c = text[i];
      if (c == '\t') {
        f.emplace_back();
      } else if (c != '\r' && c != '"') {
        f.back() += c;
      }
    }
    start = end + 1;
    if (line == 1 || (f.size() == 1 && f[0].empty())) continue;  // the header, a blank line
    if (f.size() < fields) {
      return error(ErrorCode::kInvalidData, path,
                   "line " + std::to_string(line) + ": expected " + std::to_string(fields) +
                       " tab-separated fields, got " + std::to_string(f.size()));
    }
    row(f);
  }
  if (line == 0) return error(ErrorCode::kInvalidData, path, "empty table");
  return {};
}

/// The identifier that starts with `prefix` followed by digits in `stem` ("FMA24474" in
/// "FJ3171_BP..._FMA24474_Right_femur"), or "".
std::string id_in(const std::string& stem, const std::string& prefix) {
  for (size_t at = stem.find(prefix); at != std::string::npos; at = stem.find(prefix, at + 1)) {
    if (at > 0 && std::isalnum(static_cast<unsigned char>(stem[at - 1]))) continue;
    size_t end = at + prefix.size();
    while (end < stem.size() && std::isdigit(static_cast<unsigned char>(stem[end]))) ++end;
    if (end > at + prefix.size()) return stem.substr(at, end - at);
  }
  return "";
}

/// Distances (edges up the part-of graph) from the start nodes to every ancestor; UINT32_MAX: not
/// an ancestor.
std::vector<uint32_t> distances_up(const Ontology& o, const std::vector<uint32_t>& starts) {
  std::vector<uint32_t> dist(o.names.size(), UINT32_MAX);
  std::vector<uint32_t> front;
  for (uint32_t s : starts) {
    if (dist[s] != 0) front.push_back(s);
    dist[s] = 0;
  }
  while (!front.empty()) {
    std::vector<uint32_t> next;
    for (uint32_t n : front) {
      for (uint32_t p : o.parents[n]) {
        if (dist[p] == UINT32_MAX) {
          dist[p] = dist[n] + 1;
          next.push_back(p);
        }
      }
    }
    front = std::move(next);
  }
  return dist;
}

/// The nearest of `concepts` (English names) by `dist`; UINT32_MAX when none is above.
uint32_t nearest(const Ontology& o, const std::vector<uint32_t>& dist,
                 const std::vector<std::string_view>& concepts) {
  uint32_t best = UINT32_MAX;
  for (std::string_view name : concepts) {
    const auto it = o.by_name.find(std::string(name));
    if (it == o.by_name.end()) continue;
    for (uint32_t n : it->second) best = std::min(best, dist[n]);
  }
  return best;
}

}  // namespace

Result<std::vector<Placement>> place_by_fma(const std::string& dir,
                                            const std::vector<std::string>& stems) {
  const std::string folder = dir.empty() || dir.back() == '/' ? dir : dir + "/";
  std::string tables[3];
  const char* const files[3] = {"conventional_part_of.txt", "isa_element_parts.txt",
                                "parts_list_e.txt"};
  for (int k = 0; k < 3; ++k) {
    OSTEON_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, read_file(folder + files[k]));
    tables[k].assign(bytes.begin(), bytes.end());
  }
  return place_by_fma_tables(tables[0], tables[1], tables[2], dir, stems);
}

Result<std::vector<Placement>> place_by_fma_tables(const std::string& part_of,
                                                   const std::string& isa,
                                                   const std::string& names_list,
                                                   const std::string& dir,
                                                   const std::vector<std::string>& stems) {
  Ontology o;
  const std::string folder = dir.empty() || dir.back() == '/' ? dir : dir + "/";
  OSTEON_RETURN_IF_ERROR(parse_table(part_of, folder + "conventional_part_of.txt", 4,
                                     [&](const std::vector<std::string>& f) {
                                       const uint32_t parent = o.node(f[0]);
                                       const uint32_t child = o.node(f[2]);
                                       o.name(parent, f[1]);
                                       o.name(child, f[3]);
                                       if (parent != child) o.parents[child].push_back(parent);
                                     }));
  OSTEON_RETURN_IF_ERROR(
      parse_table(isa, folder + "isa_element_parts.txt", 3, [&](const std::vector<std::string>& f) {
        const uint32_t concept_id = o.node(f[0]);
        const uint32_t element = o.node(f[2]);
        o.name(concept_id, f[1]);
        if (concept_id != element) o.parents[element].push_back(concept_id);
      }));
  OSTEON_RETURN_IF_ERROR(
      parse_table(names_list, folder + "parts_list_e.txt", 2,
                  [&](const std::vector<std::string>& f) { o.name(o.node(f[0]), f[1]); }));
  for (uint32_t n = 0; n < o.names.size(); ++n) {
    if (!o.names[n].empty()) o.by_name[o.names[n]].push_back(n);
  }

  std::vector<Placement> out(stems.size());
  for (size_t s = 0; s < stems.size(); ++s) {
    std::vector<uint32_t> starts;
    const std::string fma = id_in(stems[s], "FMA");
    const std::string fj = id_in(stems[s], "FJ");
    for (const std::string& id : {fma, fj}) {
      const auto it = id.empty() ? o.index.end() : o.index.find(id);
      if (it != o.index.end()) starts.push_back(it->second);
    }
    if (starts.empty()) continue;
    const std::vector<uint32_t> dist = distances_up(o, starts);
    size_t region = SIZE_MAX;
    uint32_t best = UINT32_MAX;
    for (size_t r = 0; r < kRegionRuleCount; ++r) {
      if (!kRegionRules[r].subregion.empty()) continue;
      const uint32_t d = nearest(o, dist, kRegionRules[r].concepts);
      if (d < best) {
        best = d;
        region = r;
      }
    }
    if (region == SIZE_MAX) continue;
    size_t subregion = SIZE_MAX;
    best = UINT32_MAX;
    for (size_t r = region + 1; r < kRegionRuleCount && !kRegionRules[r].subregion.empty(); ++r) {
      const uint32_t d = nearest(o, dist, kRegionRules[r].concepts);
      if (d < best) {
        best = d;
        subregion = r;
      }
    }
    // The side is in the concept's English name ("right femur"), else in the stem.
    const auto named = fma.empty() ? o.index.end() : o.index.find(fma);
    std::string side = named != o.index.end() ? side_of(name_words(o.names[named->second])) : "";
    if (side.empty()) side = side_of(name_words(stems[s]));
    out[s].path = region_path(region, subregion, side);
    out[s].rank = region_rank(region, subregion, side);
    best = UINT32_MAX;
    for (size_t k = 0; k < kSystemRuleCount; ++k) {
      const uint32_t d = nearest(o, dist, kSystemRules[k].concepts);
      if (d < best) {
        best = d;
        out[s].system = std::string(kSystemRules[k].name);
      }
    }
  }
  return out;
}

}  // namespace osteon::detail
