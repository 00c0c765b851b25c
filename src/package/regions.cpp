// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <cctype>
#include <string>
#include <string_view>
#include <vector>

#include "osteon/mesh.hpp"
#include "package/package_internal.hpp"

// Regions (docs/FORMAT.md "Regions"): a part's place in the skeleton (Skeleton / Upper limb /
// Right / Hand) and its system, derived from an anatomy source when the names file gives none.
// The derivation is the table below plus two readings of it: by the words of the part's name
// (TotalSegmentator's "rib_left_7", Slicer's "Left femur"), or by BodyParts3D's FMA ontology
// tables (regions_fma.cpp). The table is the whole mapping: a region or sub-region is named
// once, with the FMA concepts and the name words that place a bone in it.

namespace osteon::detail {

namespace {

// Word patterns: "rib*" is a word start, "t1" a whole word.
using Words = std::vector<std::string_view>;

}  // namespace

// Rows in priority order: the first region whose words a name matches wins (the FMA reading takes
// the region nearest in the ontology instead, ties in this order); a sub-region row follows its
// region's row and is only tried for bones of that region.
const RegionRule kRegionRules[] = {
    {"Skull", "", {"skull", "hyoid bone"},
     Words{"skull", "cranium", "mandible", "maxilla", "hyoid", "frontal", "parietal", "occipital",
           "temporal", "sphenoid", "ethmoid", "nasal", "zygomatic", "lacrimal", "palatine",
           "vomer"}},
    {"Vertebral column", "", {"vertebral column", "intervertebral disk"},
     Words{"vertebra*", "sacrum*", "sacral*", "coccyx*", "intervertebral*", "atlas", "axis"}},
    {"Vertebral column", "Cervical", {"set of cervical vertebrae"},
     Words{"c1", "c2", "c3", "c4", "c5", "c6", "c7", "cervical*", "atlas", "axis"}},
    {"Vertebral column", "Thoracic", {"set of thoracic vertebrae"},
     Words{"t1", "t2", "t3", "t4", "t5", "t6", "t7", "t8", "t9", "t10", "t11", "t12",
           "thoracic*"}},
    {"Vertebral column", "Lumbar", {"set of lumbar vertebrae"},
     Words{"l1", "l2", "l3", "l4", "l5", "l6", "lumbar*"}},
    {"Vertebral column", "Sacrum", {"sacrum"},
     Words{"s1", "sacrum*", "sacral*", "coccyx*"}},
    {"Vertebral column", "Intervertebral disks", {"intervertebral disk"},
     Words{"intervertebral*", "disk*", "disc*"}},
    {"Thorax", "", {"set of ribs", "sternum", "costal cartilage"},
     Words{"rib*", "sternum*", "costal*"}},
    {"Thorax", "Ribs", {"set of ribs"}, Words{"rib*"}},
    {"Thorax", "Costal cartilages", {"costal cartilage"}, Words{"costal*"}},
    {"Upper limb", "",
     {"skeletal system of free upper limb", "skeleton of upper limb", "upper limb"},
     Words{"humer*", "radius", "ulna*", "carpal*", "metacarpal*", "scapul*", "clavic*", "hand",
           "finger*", "thumb", "scaphoid", "lunate", "triquetr*", "pisiform", "trapez*",
           "capitate", "hamate"}},
    {"Upper limb", "Shoulder girdle", {"pectoral girdle"}, Words{"scapul*", "clavic*"}},
    {"Upper limb", "Hand", {"hand"},
     Words{"carpal*", "metacarpal*", "finger*", "thumb", "hand", "scaphoid", "lunate",
           "triquetr*", "pisiform", "trapez*", "capitate", "hamate"}},
    {"Pelvis", "", {"hip bone", "pelvic girdle"},
     Words{"hip", "pelvi*", "ilium", "ischium", "pubi*", "innominate"}},
    {"Lower limb", "",
     {"skeletal system of free lower limb", "skeleton of lower limb", "lower limb"},
     Words{"femur*", "patella*", "tibia*", "fibula*", "tarsal*", "metatarsal*", "calcane*", "talus",
           "foot", "toe*", "navicular", "cuboid", "cuneiform"}},
    {"Lower limb", "Foot", {"foot"},
     Words{"tarsal*", "metatarsal*", "calcane*", "talus", "foot", "toe*", "navicular", "cuboid",
           "cuneiform"}},
};
const size_t kRegionRuleCount = std::size(kRegionRules);

// Systems, the same way: the FMA reading takes the nearest; by words, the first that matches, and
// a bone placed in a region that matches none is in the skeletal system.
const SystemRule kSystemRules[] = {
    {"Articular system", {"articular system"}, Words{"intervertebral*", "disk*", "disc*"}},
    {"Skeletal system", {"skeletal system"}, Words{}},
};
const size_t kSystemRuleCount = std::size(kSystemRules);

std::vector<std::string> name_words(std::string_view name) {
  std::vector<std::string> words;
  std::string word;
  for (char c : name) {
    if (std::isalnum(static_cast<unsigned char>(c))) {
      word += char(std::tolower(static_cast<unsigned char>(c)));
    } else if (!word.empty()) {
      words.push_back(std::move(word));
      word.clear();
    }
  }
  if (!word.empty()) words.push_back(std::move(word));
  return words;
}

bool words_match(const std::vector<std::string>& words,
                 const std::vector<std::string_view>& patterns) {
  for (std::string_view pattern : patterns) {
    const bool prefix = !pattern.empty() && pattern.back() == '*';
    if (prefix) pattern.remove_suffix(1);
    for (const std::string& word : words) {
      if (prefix ? word.rfind(pattern, 0) == 0 : word == pattern) return true;
    }
  }
  return false;
}

std::string side_of(const std::vector<std::string>& words) {
  for (const std::string& word : words) {
    if (word == "right" || word == "r" || word == "dexter" || word == "dextra") return "Right";
    if (word == "left" || word == "l" || word == "sinister" || word == "sinistra") return "Left";
  }
  return "";
}

std::vector<std::string> region_path(size_t region, size_t subregion, const std::string& side) {
  std::vector<std::string> path = {"Skeleton", std::string(kRegionRules[region].region)};
  if (!side.empty()) path.push_back(side);
  if (subregion != SIZE_MAX) path.emplace_back(kRegionRules[subregion].subregion);
  return path;
}

int32_t region_rank(size_t region, size_t subregion, const std::string& side) {
  const int32_t s = side == "Right" ? 0 : side == "Left" ? 1 : 2;
  return int32_t(region) * 1024 + s * 256 + (subregion == SIZE_MAX ? 255 : int32_t(subregion));
}

Placement place_by_words(const std::string& name) {
  const std::vector<std::string> words = name_words(name);
  Placement out;
  size_t region = SIZE_MAX;
  for (size_t r = 0; r < kRegionRuleCount && region == SIZE_MAX; ++r) {
    if (kRegionRules[r].subregion.empty() && words_match(words, kRegionRules[r].words)) region = r;
  }
  if (region == SIZE_MAX) return out;
  size_t subregion = SIZE_MAX;
  for (size_t r = region + 1; r < kRegionRuleCount && !kRegionRules[r].subregion.empty(); ++r) {
    if (words_match(words, kRegionRules[r].words)) {
      subregion = r;
      break;
    }
  }
  const std::string side = side_of(words);
  out.path = region_path(region, subregion, side);
  out.rank = region_rank(region, subregion, side);
  out.system = std::string(kSystemRules[kSystemRuleCount - 1].name);
  for (size_t s = 0; s < kSystemRuleCount; ++s) {
    if (words_match(words, kSystemRules[s].words)) {
      out.system = std::string(kSystemRules[s].name);
      break;
    }
  }
  return out;
}

Status derive_regions(const std::string& source, const std::vector<Mesh>& parts, Names* names) {
  if (source.empty()) return {};
  std::vector<std::string> stems;
  stems.reserve(parts.size());
  for (const Mesh& part : parts) stems.push_back(stem_of(part.name));
  std::vector<Placement> placed(parts.size());
  if (source == "names") {
    for (size_t p = 0; p < parts.size(); ++p) placed[p] = place_by_words(stems[p]);
  } else if (source.rfind("fma:", 0) == 0) {
    OSTEON_ASSIGN_OR_RETURN(placed, place_by_fma(source.substr(4), stems));
  } else {
    return error(ErrorCode::kInvalidArgument, source,
                 "--regions: expected \"names\" (from the part names' words) or \"fma:DIR\" "
                 "(BodyParts3D's ontology tables in DIR)");
  }
  // A part the names file already places keeps its path; a label volume's part may be named by
  // its label value there, so the derivation fills that entry.
  for (size_t p = 0; p < parts.size(); ++p) {
    if (placed[p].path.empty()) continue;
    DisplayName* found = find_display_name(*names, parts[p]);
    DisplayName& entry = found != nullptr ? *found : names->parts[stems[p]];
    if (entry.path.empty()) {
      for (const std::string& g : placed[p].path) entry.path.push_back({g, {}});
      entry.rank = placed[p].rank;
    }
    if (entry.system.empty()) entry.system = placed[p].system;
  }
  return {};
}

}  // namespace osteon::detail
