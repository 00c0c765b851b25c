// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <map>
#include <string>
#include <vector>

#include "osteon/mesh.hpp"

#include "osteon/status.hpp"
#include "osteon/vec.hpp"

// What pack's stages share inside the package module.

namespace osteon::detail {

/// The file stem of a part name or path: the last path component without its extension.
/// "bones/FJ43_x.glb" -> "FJ43_x".
std::string stem_of(const std::string& name);

/// A part's display name and group, from a names file.
struct DisplayName {
  std::string name;
  std::string group;
  bool has_color = false;
  Vec3 color{0, 0, 0};  ///< sRGB 0..1
};

/// Reads a names file (docs/FORMAT.md "Names file"): a JSON array of objects {filename|file|name,
/// label|display_name, group}, a JSON object {stem: "display name"} or {stem: {display_name|label,
/// group}}, or a CSV of stem,display_name[,group] lines (a first line starting with "file" or
/// "stem" is a header). Keys are file stems, or label values for parts of a label volume; an
/// optional colour (JSON "color", CSV 4th column) is "#rrggbb" or three numbers 0..1. Errors:
/// read_file's; kInvalidData for JSON that does not parse or a CSV line of fewer than 2 fields.
Result<std::map<std::string, DisplayName>> read_names(const std::string& path);

/// The triangles `indices` of `mesh` (corner indices, three a triangle), with only their vertices,
/// in first-use order; name, source and unit kept. O(vertices + indices).
Mesh submesh(const Mesh& mesh, const std::vector<uint32_t>& indices);

/// A coarser level of detail of a component: its triangles and its measured distance from the
/// full level (symmetric sampled Hausdorff, in the mesh's unit, before quantization).
struct DetailLevel {
  Mesh mesh;
  double distance = 0;
};

/// The chain of coarser levels of `full` (docs/FORMAT.md "Levels of detail"), coarsest first:
/// each simplified from the next finer one to a quarter of its triangles with the border locked
/// (so every level keeps `full`'s border vertices, exactly), while that leaves at least
/// kMinLevelTriangles and the simplifier gets below 3/4 of the finer level; at most
/// `max_levels` - 1 of them (0: no limit). Each level's distance from `full` is measured: the
/// larger of the sampled distances from the level (3 samples a triangle) to `full` and from
/// the vertices of `full` (at most 8 per vertex of the level, stratified) to the level.
/// Errors: those of hausdorff() (a non-finite coordinate). Deterministic.
inline constexpr uint64_t kMinLevelTriangles = 256;
Result<std::vector<DetailLevel>> detail_levels(const Mesh& full, int max_levels);

}  // namespace osteon::detail
