// SPDX-License-Identifier: Apache-2.0
#include "osteon/mesh.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <utility>

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

double unit_in_millimetres(Unit unit) {
  switch (unit) {
    case Unit::kCentimetre:
      return 10;
    case Unit::kMetre:
      return 1000;
    case Unit::kInch:
      return 25.4;
    case Unit::kMillimetre:
    case Unit::kUnknown:
      break;
  }
  return 1;
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

Mesh transform_mesh(const Mesh& mesh, const Mat4& matrix) {
  const auto& m = matrix;
  Mesh out = mesh;
  for (Vec3& p : out.positions) p = transform_point(m, p);
  // Columns of the linear part; normals go by its inverse transpose, which is the cofactor
  // matrix [c1 x c2, c2 x c0, c0 x c1] (as columns) over the determinant.
  const Vec3d c0{m[0], m[1], m[2]}, c1{m[4], m[5], m[6]}, c2{m[8], m[9], m[10]};
  const double det = dot(c0, cross(c1, c2));
  const Vec3d k0 = cross(c1, c2), k1 = cross(c2, c0), k2 = cross(c0, c1);
  for (Vec3& n : out.normals) {
    Vec3d q = double(n.x) * k0 + double(n.y) * k1 + double(n.z) * k2;
    const double length = std::sqrt(squared_length(q));
    if (length > 0) q = ((det < 0 ? -1.0 : 1.0) / length) * q;
    n = {float(q.x), float(q.y), float(q.z)};
  }
  if (det < 0) {
    for (size_t f = 0; f + 2 < out.indices.size(); f += 3) {
      std::swap(out.indices[f + 1], out.indices[f + 2]);
    }
  }
  return out;
}

}  // namespace osteon
