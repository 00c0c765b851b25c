// SPDX-License-Identifier: Apache-2.0
#include "osteon/mesh.hpp"

#include <algorithm>
#include <cctype>

namespace osteon {

const char* unit_name(Unit unit) {
  switch (unit) {
    case Unit::kMillimetre:
      return "mm";
    case Unit::kCentimetre:
      return "cm";
    case Unit::kMetre:
      return "m";
    case Unit::kInch:
      return "in";
    case Unit::kUnknown:
      break;
  }
  return "unknown";
}

bool parse_unit(const std::string& text, Unit* unit) {
  std::string t = text;
  std::transform(t.begin(), t.end(), t.begin(), [](unsigned char c) { return std::tolower(c); });
  if (t == "mm" || t == "millimetre" || t == "millimeter" || t == "millimetres" ||
      t == "millimeters") {
    *unit = Unit::kMillimetre;
  } else if (t == "cm" || t == "centimetre" || t == "centimeter" || t == "centimetres" ||
             t == "centimeters") {
    *unit = Unit::kCentimetre;
  } else if (t == "m" || t == "metre" || t == "meter" || t == "metres" || t == "meters") {
    *unit = Unit::kMetre;
  } else if (t == "in" || t == "inch" || t == "inches") {
    *unit = Unit::kInch;
  } else {
    return false;
  }
  return true;
}

void expand(Aabb& box, const Vec3& p) {
  if (box.empty) {
    box.min = box.max = p;
    box.empty = false;
    return;
  }
  box.min = {std::min(box.min.x, p.x), std::min(box.min.y, p.y), std::min(box.min.z, p.z)};
  box.max = {std::max(box.max.x, p.x), std::max(box.max.y, p.y), std::max(box.max.z, p.z)};
}

void expand(Aabb& box, const Aabb& other) {
  if (other.empty) return;
  expand(box, other.min);
  expand(box, other.max);
}

Mesh merge_parts(Scene&& scene) {
  if (scene.parts.size() == 1) return std::move(scene.parts[0]);
  Mesh merged;
  merged.name = "merged";
  for (Mesh& part : scene.parts) {
    if (merged.source.empty()) merged.source = part.source;
    merged.unit = part.unit;
    merged.unit_source = part.unit_source;
    const auto base = static_cast<uint32_t>(merged.positions.size());
    merged.positions.insert(merged.positions.end(), part.positions.begin(), part.positions.end());
    for (uint32_t i : part.indices) merged.indices.push_back(base + i);
    merged.stored_vertices += part.stored_vertices;
  }
  return merged;
}

Aabb bounding_box(const Mesh& mesh) {
  Aabb box;
  if (mesh.indices.empty()) {
    for (const Vec3& p : mesh.positions) expand(box, p);
  } else {
    std::vector<bool> seen(mesh.positions.size(), false);
    for (uint32_t i : mesh.indices) {
      if (i < seen.size() && !seen[i]) {
        seen[i] = true;
        expand(box, mesh.positions[i]);
      }
    }
  }
  return box;
}

Unit guess_unit(const Scene& scene) {
  float largest = 0;
  bool any = false;
  for (const Mesh& part : scene.parts) {
    Aabb box = bounding_box(part);
    if (box.empty) continue;
    any = true;
    largest =
        std::max({largest, box.max.x - box.min.x, box.max.y - box.min.y, box.max.z - box.min.z});
  }
  if (!any) return Unit::kUnknown;
  return largest < 3.0f ? Unit::kMetre : Unit::kMillimetre;
}

}  // namespace osteon
