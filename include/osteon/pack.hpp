// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "osteon/io.hpp"
#include "osteon/mesh.hpp"
#include "osteon/package.hpp"
#include "osteon/status.hpp"

// The whole pipeline in one call (docs/DESIGN.md "The pipeline"): read every input -> clean each
// part -> find repeated parts -> segment each prototype part into components no larger than
// max_triangles -> coarser levels of each large component -> encode every level -> write
// content-hashed chunk files and the manifest (docs/FORMAT.md "Package, version 3"; the
// manifest's types are in osteon/package.hpp).

namespace osteon {

/// The pipeline's stages, in order, as PackOptions::progress reports them. Units: inputs (read),
/// parts (clean, repeats), prototype parts (segment), components (encode), files (write).
enum class PackStage { kRead, kClean, kRepeats, kSegment, kLevels, kEncode, kWrite };

/// "read", "clean", "repeats", "segment", "levels", "encode", "write".
const char* stage_name(PackStage stage);
/// What PackOptions::progress counts in `stage`: "inputs", "parts", "parts", "parts",
/// "components" (levels: the components that get levels; encode), "files".
const char* stage_unit(PackStage stage);

struct PackOptions {
  /// The package folder; created when absent. It must be absent, an empty folder or a package
  /// (a folder with manifest.json), which is replaced whole: files the new package does not hold
  /// go with the old one (docs/DESIGN.md "Publishing a package").
  std::string output;
  /// Quantization. By default every coordinate stays within `precision_mm` millimetres of the
  /// input, in each part's unit (a part of unknown unit counts as millimetres): one bound for a
  /// phalanx and a femur alike. bits > 0 instead: bits per coordinate over each part's largest
  /// bounding-box side (EncodeOptions::bits, 8..24). precision > 0 instead: the largest
  /// coordinate error in mesh units.
  int bits = 0;
  double precision = 0;
  double precision_mm = 0.05;
  /// The tolerance of a repeat substitution in mesh units; 0: the codec's own bound
  /// (RepeatOptions::tolerance).
  double repeat_tolerance = 0;
  /// The largest component, in triangles. Parts with at most this many triangles stay whole;
  /// larger ones are segmented (segment() with SegmentOptions::max_triangles). 0: never segment.
  /// kAutomaticPieces (the default): kPieceTrianglesWithLevels when components get levels of
  /// detail, else kPieceTriangles (docs/DESIGN.md "Packing a skeleton" says why).
  uint32_t max_triangles = kAutomaticPieces;
  static constexpr uint32_t kAutomaticPieces = 0xFFFFFFFFu;
  static constexpr uint32_t kPieceTriangles = 20000;
  static constexpr uint32_t kPieceTrianglesWithLevels = 160000;
  /// Levels of detail (docs/FORMAT.md "Levels of detail"): every component with more than this
  /// many triangles also gets a chain of coarser levels, each about a quarter of the next, the
  /// coarsest first in the stream. 0: no levels.
  uint32_t lod_min_triangles = 1024;
  /// At most this many levels per component, the full one included; 0: as many as the chain
  /// gives (down to a few hundred triangles); 1: no levels (--no-lod).
  int levels = 0;
  /// Which levels of the chain a component keeps (docs/DESIGN.md, "What the levels cost"): its
  /// coarsest always (it draws the whole skeleton first); then, coarse to fine, each level that
  /// keeps all its kept levels within level_share of its full level's bytes; then, if the finest
  /// kept so far is more than a pixel off in the view of the whole package (lod_view_pixels high,
  /// showing the package's bounds' largest side), the coarsest level that is within that pixel,
  /// and no other. A coarser level is coded from scratch and costs more a triangle than a dense
  /// full level (up to twice), so the whole chain adds 25 to 70%; the levels between the share's
  /// and the view's serve only views smaller than the whole one, and the finest ones only close
  /// views, which show few components and may fetch their full levels instead. A large share
  /// keeps the whole chain; lod_view_pixels 0 keeps within the share alone.
  double level_share = 0.10;
  double lod_view_pixels = 1024;
  /// Optional file mapping part file stems to display names and groups (JSON or CSV, see
  /// docs/FORMAT.md); empty: display names are the part names.
  std::string names;
  /// Where parts the names file does not place get their regions and system from (docs/FORMAT.md
  /// "Regions"): "names" (the words of the part names: TotalSegmentator's and Slicer's classes),
  /// "fma:DIR" (BodyParts3D's ontology tables in DIR); empty: nowhere.
  std::string regions;
  /// Worker threads for the repeat search, segmentation and encoding; 0: every core.
  int threads = 0;
  /// The largest chunk file in bytes: component streams are concatenated in stream order into
  /// chunk files of at most this size (a larger stream gets a chunk of its own). Fewer, larger
  /// files cost fewer requests; smaller ones cache at a finer grain.
  uint64_t chunk_bytes = 512 * 1024;
  /// Look for repeated parts (find_repeats); false: every part stores its own components.
  bool repeats = true;
  /// A folder whose regular files (recursively, relative paths kept) are copied into the package
  /// first: the viewer (build/viewer). Empty: no viewer files. It may not hold manifest.json or
  /// anything under c/.
  std::string viewer;
  /// How inputs are read (read_path): label volumes' --labels, --threshold and smoothing. A label
  /// volume's surfaces are simplified to read.surface_precision, else to `precision`, else to
  /// read.surface_precision_voxels of a voxel (by default a quarter).
  ReadOptions read{.surface_precision_voxels = 0.25};
  /// Called as each stage advances (stage, units done, units in the stage), from the calling
  /// thread; for progress bars. May be empty.
  std::function<void(PackStage stage, uint64_t done, uint64_t total)> progress;
};

/// Wall-clock milliseconds of each stage.
struct PackTimings {
  double read_ms = 0;
  double clean_ms = 0;
  double repeats_ms = 0;
  double segment_ms = 0;
  double levels_ms = 0;  ///< simplifying the chains of levels
  double encode_ms = 0;  ///< encoding, with the distances of the levels kept
  double write_ms = 0;
  double total_ms = 0;
};

struct PackReport {
  uint64_t input_bytes = 0;          ///< sizes of the files the parts were read from
  uint64_t output_bytes = 0;         ///< chunk files plus manifest.json
  uint64_t manifest_gzip_bytes = 0;  ///< manifest.json.gz (not in output_bytes)
  uint64_t viewer_bytes = 0;         ///< the viewer's files copied in (not in output_bytes)
  size_t viewer_files = 0;
  size_t parts = 0;
  size_t prototypes = 0;  ///< parts whose components are stored (the others are instances)
  size_t components = 0;
  size_t files = 0;  ///< chunk files (equal streams are stored once)
  size_t instances = 0;
  uint64_t triangles_in = 0;   ///< over all parts after cleaning
  uint64_t triangles_out = 0;  ///< over the stored components, at full resolution
  size_t level_streams = 0;    ///< coarser levels stored, over all components
  uint64_t level_triangles = 0;  ///< their triangles
  uint64_t level_bytes = 0;      ///< their bytes (in output_bytes)
  /// The chunks that hold every component's first (coarsest) stream: what a viewer reads before
  /// the whole skeleton is drawn.
  uint64_t first_bytes = 0;
  std::string manifest;        ///< path of manifest.json
  PackTimings timings;
};

/// Packs the meshes read from `inputs` (files or folders, read_path) into options.output.
/// Deterministic: the same inputs and options give byte-identical files (no timestamps; parts in
/// input order, then read order). Nothing is written until every stage has succeeded; then the
/// package is written into a fresh folder beside options.output (".DIR.osteon-tmp-<pid>-<hex>")
/// and swapped in whole under an exclusive lock (".DIR.osteon-lock"), so DIR is always one
/// complete package, the old or the new, whatever is killed when, and two packs into one DIR
/// leave one of them (the second waits for the first's swap). What packs killed earlier left
/// beside DIR is cleaned first (docs/FORMAT.md "Beside the package folder").
/// Errors: those of read_path, segment, find_repeats and encode (naming the file); kInvalidData
/// when no part has triangles or the names file does not parse; kInvalidArgument for an empty
/// input list or output, bits/precision out of range, or an output that is a file or a folder
/// neither empty nor a package (checked before any work); kIoError when writing, locking or
/// renaming fails.
/// Known approximations: a repeat's error adds the sampled (lower-bound) Hausdorff tolerance it
/// was accepted under to the quantization bound.
Result<PackReport> pack(const std::vector<std::string>& inputs, const PackOptions& options);

/// pack() without writing anything: the manifest and chunk bytes it would write (options.output
/// and options.viewer are ignored; `report`, when given, gets every field but the written
/// files' sizes and paths). For commands that turn inputs straight into another format
/// (`osteon export`). Deterministic, and byte-identical to what pack() writes. Errors: pack's.
Result<PackageData> pack_in_memory(const std::vector<std::string>& inputs,
                                   const PackOptions& options, PackReport* report = nullptr);

}  // namespace osteon
