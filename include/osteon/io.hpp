// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "osteon/mesh.hpp"
#include "osteon/status.hpp"

// Readers and writers. Every reader treats its bytes as hostile (STYLE habit 5): counts are checked
// against the bytes that remain before anything is allocated, coordinates must be finite, indices
// in range; every error names the file and the byte offset or line.

namespace osteon {

enum class Format { kUnknown, kStl, kObj, kPly, kOff, kVtk, kGltf, kGlb };

/// "stl", "obj", "ply", "off", "vtk", "gltf", "glb" or "unknown".
const char* format_name(Format format);
/// The format a file name's extension names (case-insensitive), or Format::kUnknown.
Format format_from_extension(const std::string& path);

struct ReadOptions {
  /// Weld exactly-equal positions into shared vertices while reading (STL, a triangle soup, is
  /// welded as it streams in, so the soup is never held in memory). Mesh::stored_vertices keeps
  /// the count before welding either way.
  bool weld = true;
  /// The unit to record on every part. Unit::kUnknown: guess it from the scene's size.
  Unit unit = Unit::kUnknown;
  /// Refuse files (and, for folders, the sum of files) larger than this many bytes.
  uint64_t max_file_bytes = uint64_t{4} << 30;

  // Label volumes (.nii, .nii.gz, .nrrd, .nhdr; osteon/volume.hpp) become one part per label.
  /// The labels to take (select_labels: values, names or "bones"); empty: every label present.
  std::vector<std::string> labels;
  /// An intensity volume (a CT) gives the surface where the value is at least this (Hounsfield
  /// units), split into connected parts. Unset: intensity volumes are refused.
  std::optional<double> threshold;
  /// > 0: simplify each label's surface to this error bound, in mm (SurfaceOptions::precision).
  double surface_precision = 0;
  /// When surface_precision is 0 and this is > 0: simplify to this fraction of the volume's
  /// smallest voxel side (a surface from voxels is only known to within a voxel, so a thin-slice
  /// CT's surfaces need not keep every voxel's triangles). osteon pack sets it.
  double surface_precision_voxels = 0;
  /// Constrained smoothing passes over each surface (SurfaceOptions::smoothing_iterations).
  int smoothing_iterations = 16;

  /// A package is read with every component at this level of detail, counted from its coarsest
  /// (0), or at full resolution where it has fewer levels; -1: full resolution (read_package).
  int package_level = -1;
};

/// Reads any input osteon takes: a package folder written by osteon pack (read_package: its parts
/// as the viewer draws them, in the manifest's unit unless options.unit is given), else what
/// read_meshes reads. Errors: those of read_package and read_meshes.
Result<Scene> read_path(const std::string& path, const ReadOptions& options = {});

/// Reads one mesh file or a folder of them. A file gives one part, or several (OBJ groups, glTF
/// nodes); a folder gives every mesh file below it (recursively, in sorted path order) as named
/// parts, named by the path relative to the folder without extension, plus "/node" where one file
/// holds several parts.
/// Errors: kIoError for a missing or unreadable path, kInvalidData for bad bytes, kUnsupported for
/// a format or a feature osteon does not read, and a folder holding no mesh file is kIoError.
Result<Scene> read_meshes(const std::string& path, const ReadOptions& options = {});

/// Parses one file already in memory. `source` is the name used in messages and for part names;
/// `format` kUnknown picks the format from `source`'s extension, then from the bytes themselves.
/// A .gltf with external buffers needs read_path (the buffers are found beside the file).
Result<Scene> read_memory(const uint8_t* data, size_t size, const std::string& source,
                          Format format = Format::kUnknown, const ReadOptions& options = {});

/// Writes one mesh as binary STL, binary little-endian PLY or OBJ, chosen by the extension of
/// `path`. Writes to a temporary file beside `path` and renames it, so no half-written file is
/// ever left behind. Errors: kInvalidArgument for another extension or a mesh that breaks the
/// Mesh contract (index out of range, NaN position, normals count), kIoError when writing fails.
Status write_mesh(const std::string& path, const Mesh& mesh);

/// Reads a whole file. Errors: kIoError when it is missing, a folder or unreadable (with the
/// system's reason), kInvalidArgument when it is larger than `max_bytes` (checked before any
/// allocation).
Result<std::vector<uint8_t>> read_file(const std::string& path,
                                       uint64_t max_bytes = uint64_t{4} << 30);

/// Writes bytes to `path` through a temporary file and a rename.
Status write_file_atomic(const std::string& path, const void* data, size_t size);

}  // namespace osteon
