// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "package/package_internal.hpp"

// What fuzz/regions_fuzzer.cpp checks of one input, shared with tests/fuzz_corpus_test.cpp so the
// corpus replay asks exactly what the fuzzer asks. The input is BodyParts3D's three ontology
// tables joined by NUL bytes (conventional_part_of.txt, isa_element_parts.txt, parts_list_e.txt:
// split at the first two; a table the input lacks is empty); place_by_fma_tables places three
// fixed stems by them (a toe phalanx with an FJ and an FMA id, an FMA id alone, a stem with
// neither). An error must name one of the three tables; the placements must be one a stem, each
// path empty or region_path's for a region of kRegionRules (a sub-region of that region, a side
// Right, Left or none) with region_rank's rank, and a system empty or one of kSystemRules.

namespace osteon::fuzz {

/// What one input gave: whether it parsed, and the first broken promise ("" when none).
struct RegionsFuzzOutcome {
  bool parsed = false;
  std::string broken;
};

namespace regions_check {

/// The stems every input places.
inline const std::vector<std::string>& stems() {
  static const std::vector<std::string> s = {
      "FJ104_BP62288_FMA32644_Middle_phalanx_of_right_third_toe", "FMA24474", "x"};
  return s;
}

/// Whether `p` is a placement place_by_fma can give: no path, or region_path's with its rank.
inline bool placement_ok(const detail::Placement& p) {
  if (p.path.empty()) return p.rank == INT32_MAX;
  for (size_t r = 0; r < detail::kRegionRuleCount; ++r) {
    if (!detail::kRegionRules[r].subregion.empty()) continue;
    for (const char* side : {"", "Right", "Left"}) {
      if (p.path == detail::region_path(r, SIZE_MAX, side))
        return p.rank == detail::region_rank(r, SIZE_MAX, side);
      for (size_t sub = r + 1;
           sub < detail::kRegionRuleCount && !detail::kRegionRules[sub].subregion.empty(); ++sub) {
        if (p.path == detail::region_path(r, sub, side))
          return p.rank == detail::region_rank(r, sub, side);
      }
    }
  }
  return false;
}

inline bool system_ok(const std::string& system) {
  if (system.empty()) return true;
  for (size_t k = 0; k < detail::kSystemRuleCount; ++k) {
    if (system == detail::kSystemRules[k].name) return true;
  }
  return false;
}

}  // namespace regions_check

/// Runs one input as the fuzzer does; `dir` is the tables' folder in the error messages.
inline RegionsFuzzOutcome regions_fuzz_one(const uint8_t* data, size_t size,
                                           const std::string& dir) {
  RegionsFuzzOutcome out;
  const char* text = reinterpret_cast<const char*>(data);
  std::string tables[3];
  size_t start = 0;
  for (int k = 0; k < 3 && start <= size; ++k) {
    const void* nul = k < 2 && start < size ? std::memchr(text + start, 0, size - start) : nullptr;
    const size_t end = nul ? size_t(static_cast<const char*>(nul) - text) : size;
    if (end > start) tables[k].assign(text + start, end - start);
    start = end + 1;
  }
  Result<std::vector<detail::Placement>> placed =
      detail::place_by_fma_tables(tables[0], tables[1], tables[2], dir, regions_check::stems());
  if (!placed.ok()) {
    const std::string& message = placed.status().message();
    bool named = false;
    for (const char* file :
         {"conventional_part_of.txt", "isa_element_parts.txt", "parts_list_e.txt"}) {
      const std::string prefix = dir + "/" + file + ": ";
      if (message.rfind(prefix, 0) == 0 && message.size() > prefix.size()) named = true;
    }
    if (!named) out.broken = "message without a table's name: " + message;
    return out;
  }
  out.parsed = true;
  if (placed->size() != regions_check::stems().size()) {
    out.broken = "not one placement a stem";
    return out;
  }
  for (size_t s = 0; s < placed->size(); ++s) {
    const detail::Placement& p = (*placed)[s];
    std::string path;
    for (const std::string& group : p.path) path += (path.empty() ? "" : " / ") + group;
    if (!regions_check::placement_ok(p)) {
      out.broken = "not a region path: " + regions_check::stems()[s] + ": " + path;
      return out;
    }
    if (!regions_check::system_ok(p.system)) {
      out.broken = "not a system: " + regions_check::stems()[s] + ": " + p.system;
      return out;
    }
  }
  return out;
}

}  // namespace osteon::fuzz
