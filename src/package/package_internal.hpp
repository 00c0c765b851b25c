// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "osteon/codec.hpp"
#include "osteon/hausdorff.hpp"
#include "osteon/mesh.hpp"

#include "osteon/status.hpp"
#include "osteon/vec.hpp"

// What pack's stages share inside the package module.

namespace osteon::detail {

/// The file stem of a part name or path: the last path component without its extension.
/// "bones/FJ43_x.glb" -> "FJ43_x".
std::string stem_of(const std::string& name);

/// A language tag as BCP 47 spells the common ones: a primary language of 2 or 3 letters, then
/// subtags of 1 to 8 letters or digits after hyphens ("en", "la", "pt-BR", "zh-Hant-TW").
bool is_language_tag(const std::string& tag);

/// A group of a part's path in a names file: its name, and its names in other languages.
struct GroupName {
  std::string name;
  std::map<std::string, std::string> names;  ///< language tag -> name
};

/// The rank of a names file's first entry: above every region_rank.
inline constexpr int32_t kNamesFileRank = 1 << 24;

/// A part's display name and group, from a names file.
struct DisplayName {
  std::string name;
  std::string group;
  bool has_color = false;
  Vec3 color{0, 0, 0};                       ///< sRGB 0..1
  std::vector<GroupName> path;               ///< its groups, outermost first; empty: none
  std::map<std::string, std::string> names;  ///< language tag -> the part's name in it
  std::string system;                        ///< "Skeletal system", "Cartilage"; empty: none
  /// Where the path's groups go among their siblings: derived paths by the region table's
  /// head-to-toe order (region_rank), a names file's own after them in the file's order
  /// (kNamesFileRank + the entry's index).
  int32_t rank = INT32_MAX;
};

/// A names file: the entries by key, and the languages of their names (the first is the
/// language of the display names; empty when no entry has names in other languages).
struct Names {
  std::vector<std::string> languages;
  std::map<std::string, DisplayName> parts;
};

/// Reads a names file (docs/FORMAT.md "Names file"): a JSON array of objects {filename|file|name,
/// label|display_name, group, path, names, system}, the same array as {"languages": [...],
/// "parts": [...]}, a JSON object {stem: "display name"} or {stem: {display_name|label, group}},
/// or a CSV of stem,display_name[,group] lines (a first line starting with "file" or "stem" is a
/// header, whose column names may add path, system and name:<tag> columns). Keys are file stems,
/// or label values for parts of a label volume; an optional colour (JSON "color", CSV 4th column)
/// is "#rrggbb" or three numbers 0..1. Errors: read_file's; kInvalidData naming the file and
/// entry for JSON that does not parse, a CSV line of fewer than 2 fields, a bad colour, a
/// malformed or repeated language tag, a name in a language the file does not list, an empty
/// group name or a path deeper than kMaxGroupDepth.
Result<Names> read_names(const std::string& path);

/// The names-file entry of `part`: by its file stem, else (a label volume's part) by its label
/// value; nullptr when there is none.
const DisplayName* find_display_name(const Names& names, const Mesh& part);
DisplayName* find_display_name(Names& names, const Mesh& part);

/// read_names on a names file's bytes, already in memory: the same forms and checks, with
/// `source` (the file's name) starting every error message. Errors: kInvalidData as read_names.
/// A part's path has at most kMaxGroupDepth groups, each named and none twice; the languages are
/// unique. O(bytes + groups * log(groups)).
Result<Names> parse_names(const std::vector<uint8_t>& bytes, const std::string& source);

/// Where a part sits in the skeleton: its groups, outermost first (empty: not placed), and its
/// system.
struct Placement {
  std::vector<std::string> path;
  std::string system;
  int32_t rank = INT32_MAX;  ///< the order of its groups among their siblings (DisplayName::rank)
};

/// A row of the region table (regions.cpp, docs/FORMAT.md "Regions"): a region, or a sub-region
/// of the region of the row before it; the FMA concepts (English names in BodyParts3D's tables)
/// whose parts are in it; the name words that place a bone in it ("rib*": a word start).
struct RegionRule {
  std::string_view region;
  std::string_view subregion;  ///< empty: the row is the region itself
  std::vector<std::string_view> concepts;
  std::vector<std::string_view> words;
};
/// A system and what places a part in it, as RegionRule.
struct SystemRule {
  std::string_view name;
  std::vector<std::string_view> concepts;
  std::vector<std::string_view> words;
};
extern const RegionRule kRegionRules[];
extern const size_t kRegionRuleCount;
extern const SystemRule kSystemRules[];
extern const size_t kSystemRuleCount;

/// The lower-case words of a name: runs of letters and digits ("rib_left_7" -> rib, left, 7).
std::vector<std::string> name_words(std::string_view name);
/// Whether a word is one of `patterns` (a pattern ending in '*' matches the words it starts).
bool words_match(const std::vector<std::string>& words,
                 const std::vector<std::string_view>& patterns);
/// "Right" or "Left" when a word says so (English, Latin, or "r"/"l" as in "femur_l"), else "".
std::string side_of(const std::vector<std::string>& words);
/// Skeleton / region / [side /] [sub-region], for rows of kRegionRules (`subregion` SIZE_MAX: none).
std::vector<std::string> region_path(size_t region, size_t subregion, const std::string& side);
/// The rank of that path: by region row, then side (right, left, none), then sub-region row.
int32_t region_rank(size_t region, size_t subregion, const std::string& side);

/// A part placed by the words of its name (TotalSegmentator's and Slicer's class names).
Placement place_by_words(const std::string& name);

/// Parts placed by BodyParts3D's ontology tables in `dir` (conventional_part_of.txt,
/// isa_element_parts.txt, parts_list_e.txt): each stem's FMA id ("FMA24474" in it) and FJ file id
/// (its leading "FJ<n>") are looked up, and the region is the one whose concepts are nearest
/// above it in the part-of graph (the element's is-a concepts count as its parents). A stem
/// without an FMA id, or one the tables do not place, gets an empty placement. Errors:
/// read_file's for a missing table; kInvalidData naming the file and line for a malformed one.
Result<std::vector<Placement>> place_by_fma(const std::string& dir,
                                            const std::vector<std::string>& stems);

/// place_by_fma on the three tables' texts, already in memory (conventional_part_of.txt,
/// isa_element_parts.txt, parts_list_e.txt, in that order); error messages name each table as
/// the file of that name in `dir` ("DIR/parts_list_e.txt: line 3: ..."). Errors: kInvalidData for
/// an empty table or a line of too few tab-separated fields. Every placement's path is empty or
/// region_path's. O(table bytes + stems * graph size).
Result<std::vector<Placement>> place_by_fma_tables(const std::string& part_of,
                                                   const std::string& isa,
                                                   const std::string& names_list,
                                                   const std::string& dir,
                                                   const std::vector<std::string>& stems);

/// Fills the path and system of every part the names file leaves unplaced, from `source`:
/// "names" (place_by_words) or "fma:DIR" (place_by_fma); empty: nothing. kInvalidArgument for
/// another source.
Status derive_regions(const std::string& source, const std::vector<Mesh>& parts, Names* names);

/// The triangles `indices` of `mesh` (corner indices, three a triangle), with only their vertices,
/// in first-use order; name, source and unit kept. O(vertices + indices).
Mesh submesh(const Mesh& mesh, const std::vector<uint32_t>& indices);

/// The chain of coarser levels of `full` (docs/FORMAT.md "Levels of detail"), coarsest first:
/// each simplified from the next finer one to a quarter of its triangles with the border locked
/// (so every level keeps `full`'s border vertices, exactly), while that leaves at least
/// kMinLevelTriangles and the simplifier gets below 3/4 of the finer level; at most
/// `max_levels` - 1 of them (0: no limit). Each island of `full` (triangles sharing vertices) is
/// simplified on its own, islands under 64 triangles kept whole; meshopt's error is held under
/// 5% of the piece's extent, which ends the chain where a quarter would cost more.
/// Deterministic. Distances are measured apart (level_distance), for the levels a package keeps.
inline constexpr uint64_t kMinLevelTriangles = 256;
std::vector<Mesh> detail_levels(const Mesh& full, int max_levels);

/// How densely level_distance samples.
enum class LevelSampling {
  /// For the level's grid step alone: 3 samples a level triangle and a quarter of the full
  /// vertices (stratified), about a third of the work. It may miss the largest distance, which
  /// only gives a finer step.
  kEstimate,
  /// The error a package records: 30 samples a level triangle and every full vertex. A coarse
  /// level's largest distance lies inside its large triangles; at compare's 10 a triangle the
  /// phantom's levels measured up to 8% under what compare found, at 30 within 1%.
  kMeasure,
};

/// A level's distance from `full` (symmetric sampled Hausdorff, in the mesh's unit): the larger
/// of the sampled distances from the level to `full`, through `to_full` (built on `full`), and
/// from the vertices of `full` to the level, sampled as `sampling` says.
/// Errors: those of hausdorff() (a non-finite coordinate).
Result<double> level_distance(const Mesh& full, const DistanceQuery& to_full, const Mesh& level,
                              LevelSampling sampling);

// How a coarser level is stored (src/package/level_grid.cpp).

/// The grid step of a coarser level that is `distance` from the full level, on a part grid of
/// `step`: the part's step times the largest power of two (at most 2^16) that moves a vertex
/// (sqrt(3) / 2 steps at most) by no more than twice the distance. The level's error is then
/// measured as quantized (pack records it): the simplification's and the quantization's errors
/// seldom peak at one place, so it is about 1.1 times the distance, not 3.
double level_step(double step, double distance);

/// Per vertex of `mesh`, 1 where it lies on an edge that does not have exactly two triangles (the
/// border that meshopt_SimplifyLockBorder keeps), else 0. O(T log T).
std::vector<uint8_t> border_vertices(const Mesh& mesh);

/// `mesh` with every vertex off its border (border_vertices) moved to the nearest point of the
/// lattice of `period` steps of `grid` (origin on a plane), each coordinate then within
/// period / 2 steps of where it was; border vertices stay where they are, so the pieces of one
/// part still meet exactly, and so do the corners of a triangle that the move would make
/// degenerate (the encoder would drop it). Positions are written as the codec's dequantization
/// writes them, so encoding on `grid` finds them on the lattice exactly.
Mesh snap_inside_border(const Mesh& mesh, const QuantizationGrid& grid, uint32_t period);

}  // namespace osteon::detail
