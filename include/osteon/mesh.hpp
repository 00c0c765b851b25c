// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "osteon/vec.hpp"

// The data every stage passes on: an indexed triangle mesh with a name and a unit, and a scene of
// named parts. Plain structs, free functions (meshoptimizer, pmp-library's simple interface).

namespace osteon {

/// The length unit a mesh's coordinates are in. Most mesh formats do not say; see
/// Mesh::unit_source.
enum class Unit { kUnknown, kMillimetre, kCentimetre, kMetre, kInch };

/// Where Mesh::unit came from.
enum class UnitSource {
  kUnknown,  ///< nobody said and nothing was guessed
  kUser,     ///< given on the command line or in ReadOptions
  kGuessed,  ///< guessed from the size of the scene (guess_unit)
};

/// An indexed triangle mesh: positions, three indices per triangle (counter-clockwise seen from
/// outside), optional per-vertex normals, the part's name and the unit it was read in.
struct Mesh {
  std::string name;    ///< part name: file stem, glTF node name, OBJ group, ...
  std::string source;  ///< the file it was read from (empty when generated)
  Unit unit = Unit::kUnknown;
  UnitSource unit_source = UnitSource::kUnknown;
  std::vector<Vec3> positions;
  std::vector<uint32_t> indices;  ///< 3 per triangle, each < positions.size()
  std::vector<Vec3> normals;      ///< empty, or one per position
  /// Vertices as stored in the file before any welding (an STL stores 3 per triangle).
  size_t stored_vertices = 0;
  /// The part's display colour (sRGB, each 0..1) when its source gives one (a label volume's
  /// table); pack passes it on to the viewer.
  bool has_color = false;
  Vec3 color{0, 0, 0};
  /// The label value the part was extracted from (label volumes); 0 otherwise. A names file may
  /// key a part by it.
  uint32_t label = 0;

  size_t vertex_count() const { return positions.size(); }
  size_t triangle_count() const { return indices.size() / 3; }
};

/// A skeleton as it arrives: a list of named parts (one per bone file, glTF node or OBJ group).
struct Scene {
  std::vector<Mesh> parts;
};

/// "mm", "cm", "m", "in" or "unknown".
const char* unit_name(Unit unit);
/// How many millimetres one `unit` is (1 for kUnknown: unknown data is taken as millimetres).
double unit_in_millimetres(Unit unit);
/// Parses "mm", "cm", "m", "in" (and the long names); returns false for anything else.
bool parse_unit(const std::string& text, Unit* unit);
/// Guesses the unit of a scene of human bones from its size: a skeleton part spans 5 mm to 2 m, so
/// a scene whose largest bounding-box side is below 3 is in metres, otherwise in millimetres.
/// Known approximation: a heuristic for anatomy only; callers mark the result UnitSource::kGuessed.
Unit guess_unit(const Scene& scene);

struct Aabb {
  Vec3 min{0, 0, 0};
  Vec3 max{0, 0, 0};
  bool empty = true;
};
/// Grows `box` to hold `p` (an empty box becomes the point).
void expand(Aabb& box, const Vec3& p);
/// Grows `box` to hold `other` (an empty `other` changes nothing).
void expand(Aabb& box, const Aabb& other);
/// Every part of a scene in one mesh, in part order (their positions, then their triangles,
/// concatenated); a single part is moved out unchanged. The name is "merged" for several parts.
Mesh merge_parts(Scene&& scene);

/// The bounding box of the positions that triangles reference (all positions when `indices` is
/// empty).
Aabb bounding_box(const Mesh& mesh);

/// `mesh` with every position mapped by the column-major 4x4 `matrix` (transform_point: in
/// double precision, rounded once to float) and its normals by the inverse transpose; the winding
/// is reversed when the matrix mirrors, so the surface still faces outward.
Mesh transform_mesh(const Mesh& mesh, const Mat4& matrix);

// ---------------------------------------------------------------------------------------------
// Welding and degenerate triangles (src/core/weld.cpp)

struct WeldOptions {
  /// 0: merge only positions that are exactly equal (-0 equals +0). > 0: also merge positions
  /// closer than this (in mesh units), clustering greedily in a hash grid of this cell size.
  float tolerance = 0.0f;
};

struct WeldReport {
  size_t vertices_before = 0;
  size_t vertices_after = 0;
};

/// Merges equal (or, with a tolerance, nearby) positions into shared vertices and rewrites the
/// indices. The first vertex of each group is kept (its position and normal) and vertices keep
/// their first-occurrence order. Unreferenced vertices stay (welded like the others): diagnosis
/// reports them, remove_unreferenced_vertices drops them.
/// Complexity: O(n) expected (hash table), O(n) extra memory.
WeldReport weld(Mesh& mesh, const WeldOptions& options = {});

/// Drops positions (and normals) no triangle references; returns how many were dropped.
size_t remove_unreferenced_vertices(Mesh& mesh);

/// True when the triangle repeats an index or has zero area (its cross product is exactly zero in
/// double precision).
bool is_degenerate_triangle(const Mesh& mesh, size_t triangle);
/// The number of degenerate triangles (repeated index or zero area).
size_t count_degenerate_triangles(const Mesh& mesh);
/// Removes degenerate triangles, keeping the order of the others; returns how many were removed.
size_t remove_degenerate_triangles(Mesh& mesh);

}  // namespace osteon
