// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "osteon/codec.hpp"
#include "osteon/mesh.hpp"
#include "osteon/status.hpp"
#include "osteon/vec.hpp"

// The package format (docs/FORMAT.md "Package, version 3") as plain data: what osteon pack
// writes, what read_package and the viewer (web/viewer/manifest.mjs) read. One writer and one
// parser; both the C++ parser and the viewer's are tested on the same golden manifests
// (tests/data/manifests).

namespace osteon {

/// The manifest version this build writes (it reads this one and version 2, which has no levels).
inline constexpr int kManifestVersion = 3;

/// A chunk file: component streams concatenated in stream order.
struct ManifestChunk {
  std::string file;  ///< "c/<24 lower-case hex digits>.ostc", relative to the package folder
  uint64_t bytes = 0;
};

/// A named part (one bone); its index in Manifest::parts is its id.
struct ManifestPart {
  std::string name;          ///< the part's name in the input (file stem, glTF node)
  std::string display_name;  ///< what the viewer shows
  std::string group;
  std::string source;  ///< the input file's name
  uint64_t triangles = 0;
  uint64_t prototype = 0;  ///< the part whose components it draws (itself unless a repeat)
  bool has_color = false;  ///< "color" is written only when set
  Vec3 color{0, 0, 0};     ///< sRGB, each 0..1
  /// Index into Manifest::groups of the part's deepest group (its path is that group and its
  /// ancestors); -1: none. When set, `group` is the path's names joined with " / ".
  int64_t path = -1;
  /// The part's name in other languages: language tag -> name, each tag in Manifest::languages.
  std::map<std::string, std::string> names;
  std::string system;  ///< e.g. "Skeletal system", "Cartilage"; empty: none
};

/// A node of the tree of regions parts are grouped in ("Skeleton" > "Lower limb" > "Right").
struct ManifestGroup {
  std::string name;     ///< non-empty, in the manifest's first language
  int64_t parent = -1;  ///< index of an earlier group; -1 for a root
  /// The group's name in other languages: language tag -> name, each tag in Manifest::languages.
  std::map<std::string, std::string> names;
};

/// The most languages, groups and group levels a manifest may hold (docs/FORMAT.md "Groups and
/// languages").
inline constexpr size_t kMaxLanguages = 64;
inline constexpr size_t kMaxGroups = 65536;
inline constexpr int kMaxGroupDepth = 32;

/// A coarser level of detail of a component (docs/FORMAT.md "Levels of detail").
struct ManifestLevel {
  uint64_t chunk = 0;  ///< index into Manifest::chunks
  uint64_t offset = 0;
  uint64_t bytes = 0;
  uint64_t triangles = 0;
  uint64_t vertices = 0;
  /// Measured (sampled Hausdorff) distance from the full level before quantization, plus the
  /// component's error_bound; in the manifest's unit.
  double error = 0;
};

/// One encoded stream: a byte range of a chunk (the component at full resolution), and its
/// coarser levels.
struct ManifestComponent {
  std::string id;
  uint64_t chunk = 0;  ///< index into Manifest::chunks
  uint64_t offset = 0;
  uint64_t bytes = 0;
  uint64_t triangles = 0;
  uint64_t vertices = 0;
  Aabb bounds;             ///< in the prototype's frame
  double error_bound = 0;  ///< the largest distance of a decoded vertex from the input, in unit
  /// Coarser levels, coarsest first, each with fewer triangles than the next (the last one's
  /// next is the full level above); empty for a component without levels.
  std::vector<ManifestLevel> levels;
};

/// A component drawn for a part under a matrix.
struct ManifestInstance {
  uint64_t part = 0;
  std::string component;  ///< a ManifestComponent::id
  Mat4 matrix = kIdentityMatrix;
  bool mirror = false;     ///< determinant3(matrix) < 0: drawn with the winding reversed
  double error_bound = 0;  ///< the component's bound plus the repeat substitution's tolerance
};

struct Manifest {
  /// The .ostm version of every stream in the package; 0 when the manifest does not say
  /// (packages written before it did, whose streams are version 1 or 2).
  int stream_version = kStreamVersion;
  Unit unit = Unit::kUnknown;
  Aabb bounds;  ///< of every part, in world coordinates
  /// When the patient's axes are known (parts from label volumes, in LPS): the viewer's up
  /// (superior) and the direction from the skeleton to the camera (anterior). "view" is written
  /// only when set; without it the viewer takes the box's longest side as up.
  bool has_view = false;
  Vec3 view_up{0, 0, 1};
  Vec3 view_eye{0, -1, 0};
  /// Language tags (BCP 47: "en", "la", "pt-BR"), unique; the first is the language of every
  /// display_name and group name; empty: display names only.
  std::vector<std::string> languages;
  /// The region tree, each group after its parent; empty: parts carry only their group string.
  std::vector<ManifestGroup> groups;
  std::vector<ManifestChunk> chunks;
  std::vector<ManifestPart> parts;
  std::vector<ManifestComponent> components;
  std::vector<ManifestInstance> instances;
  std::vector<std::string> stream_order;  ///< every component id once, in fetch order
};

/// The manifest.json text: compact JSON (keys sorted), every coordinate, matrix entry and bound
/// printed as the shortest decimal of the nearest float (bounds rounded up, never below), a final
/// newline. Deterministic: equal manifests give equal bytes. O(size).
std::string write_manifest(const Manifest& manifest);

/// Parses and checks manifest.json text: every field the format requires, each in range (chunk
/// file names c/<24 hex>.ostc only, chunk and part indices, byte ranges inside their chunk, ids
/// unique and known, every number within a float's range, 16 numbers in a matrix that is
/// non-singular in double and once rounded to float (as drawn), boxes with min <= max, levels
/// with increasing triangles and errors not below the component's bound, every component once in
/// stream_order; languages well-formed and unique, groups after their parents and at most 32
/// deep, names only in the manifest's languages, part paths naming a group). Reads versions 2
/// and 3. Errors: kInvalidData naming `source` and the JSON path
/// ("instances[3].matrix: ..."); kUnsupported for another version. Allocates O(size).
Result<Manifest> parse_manifest(const uint8_t* data, size_t size, const std::string& source);

/// A package in memory: its manifest and the bytes of its chunk files (chunks[k] holds
/// manifest.chunks[k]), as load_package reads it or pack_in_memory builds it.
struct PackageData {
  Manifest manifest;
  std::vector<std::vector<uint8_t>> chunks;
  std::string source;  ///< what messages name: the manifest's path, or "pack" when built in memory
};

/// Reads a package folder's manifest (parse_manifest) and every chunk it names, each checked to
/// be the size the manifest says. Errors: as read_package's, before any stream is decoded.
Result<PackageData> load_package(const std::string& dir);

/// True when `dir` is a folder holding a manifest.json (read_path then reads it as a package).
bool is_package(const std::string& dir);

/// Reads a package back as the parts a viewer draws: each part the merge of its instances'
/// decoded components under their matrices (mirrored ones with the winding reversed), named as
/// in the manifest, in its unit. For measuring what is shown: `osteon compare ORIGINAL PACKAGE`.
/// Errors: parse_manifest's (naming manifest.json and the JSON path); kInvalidData for a chunk
/// of another size than the manifest's; read_file's for a missing chunk (only c/<hex>.ostc names
/// inside the package are ever opened); the decoder's errors (naming chunk and offset).
/// `level` >= 0 draws every component at that level counted from its coarsest (0), or at its full
/// level when it has fewer; -1 (the default) at full resolution.
Result<Scene> read_package(const std::string& dir, int level = -1);

}  // namespace osteon
