// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <cctype>
#include <charconv>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "osteon/volume.hpp"

// Which labels of a volume become parts: values, names, or the preset "bones", which picks the
// skeleton by the labels' names. The names come from the segmenters' own tables, so the preset is
// a word list, not a list of label numbers: TotalSegmentator writes "vertebrae_T11",
// "rib_left_7", "costal_cartilages", "hip_left"; Slicer's segment names read "Left femur",
// "Vertebra L1", "Rib 7 left". A name is a bone when one of its words starts with a bone word and
// none names soft tissue ("spinal_cord" is not a vertebra).

namespace osteon {

namespace {

/// Word starts that name bones (and the costal cartilages, which a skeleton shows with the ribs).
constexpr std::string_view kBoneWords[] = {
    "bone",   "skull",  "cranium",    "mandible", "maxilla", "hyoid",  "vertebra",   "sacrum",
    "coccyx", "rib",    "sternum",    "costal",   "clavic",  "scapul", "humer",      "radius",
    "ulna",   "carpal", "metacarpal", "phalan",   "hip",     "pelvi",  "ilium",      "ischium",
    "pubi",   "femur",  "patella",    "tibia",    "fibula",  "tarsal", "metatarsal", "calcane",
    "talus",  "spine",  "atlas",      "axis"};

/// Words that name soft tissue beside a bone word ("spinal cord", "pelvic vein").
constexpr std::string_view kSoftWords[] = {"cord",  "canal",  "artery", "vein", "vena",  "muscle",
                                           "nerve", "marrow", "disc",   "fat",  "cavity"};

/// The lower-case words of a name ("vertebrae_T11" -> "vertebrae", "t11").
std::vector<std::string> words_of(const std::string& name) {
  std::vector<std::string> words(1);
  for (char c : name) {
    if (std::isalnum(static_cast<unsigned char>(c))) {
      words.back() += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    } else if (!words.back().empty()) {
      words.emplace_back();
    }
  }
  if (words.back().empty()) words.pop_back();
  return words;
}

bool any_word_starts_with(const std::vector<std::string>& words, const std::string_view* list,
                          size_t count) {
  for (const std::string& word : words) {
    for (size_t i = 0; i < count; ++i) {
      if (word.rfind(list[i], 0) == 0) return true;
    }
  }
  return false;
}

std::string lower(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

const VolumeLabel* find_by_value(const LabelVolume& volume, uint32_t value) {
  for (const VolumeLabel& label : volume.table) {
    if (label.value == value) return &label;
  }
  return nullptr;
}

}  // namespace

bool is_bone_name(const std::string& name) {
  const std::vector<std::string> words = words_of(name);
  return any_word_starts_with(words, kBoneWords, std::size(kBoneWords)) &&
         !any_word_starts_with(words, kSoftWords, std::size(kSoftWords));
}

Result<std::vector<uint32_t>> select_labels(const LabelVolume& volume,
                                            const std::vector<std::string>& selection) {
  std::vector<uint32_t> present;
  for (size_t d = 1; d < volume.values.size(); ++d) present.push_back(volume.values[d]);
  std::sort(present.begin(), present.end());
  if (selection.empty()) return present;
  auto is_present = [&](uint32_t value) {
    return std::binary_search(present.begin(), present.end(), value);
  };
  std::set<uint32_t> chosen;
  for (const std::string& item : selection) {
    if (item == "bones") {
      size_t found = 0;
      for (uint32_t value : present) {
        const VolumeLabel* label = find_by_value(volume, value);
        if (label != nullptr && is_bone_name(label->name)) {
          chosen.insert(value);
          ++found;
        }
      }
      if (found == 0) {
        return error(ErrorCode::kInvalidArgument, volume.source,
                     "--labels bones: no label present is named as a bone (the volume's labels "
                     "have no names, or none is skeletal); give label values instead");
      }
      continue;
    }
    uint32_t value = 0;
    const auto [end, ec] = std::from_chars(item.data(), item.data() + item.size(), value);
    if (ec == std::errc() && end == item.data() + item.size()) {
      if (!is_present(value)) {
        return error(ErrorCode::kInvalidArgument, volume.source,
                     "--labels: label " + item + " is not present in the volume");
      }
      chosen.insert(value);
      continue;
    }
    const VolumeLabel* match = nullptr;
    for (const VolumeLabel& label : volume.table) {
      if (lower(label.name) == lower(item)) match = &label;
    }
    if (match == nullptr) {
      return error(ErrorCode::kInvalidArgument, volume.source,
                   "--labels: no label is named \"" + item + "\"");
    }
    if (match->voxels == 0 || !is_present(match->value)) {
      return error(ErrorCode::kInvalidArgument, volume.source,
                   "--labels: \"" + item + "\" (label " + std::to_string(match->value) +
                       ") is named in the label table but not present in the volume");
    }
    chosen.insert(match->value);
  }
  return std::vector<uint32_t>(chosen.begin(), chosen.end());
}

}  // namespace osteon
