// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "osteon/package.hpp"
#include "osteon/status.hpp"

// A package as one glTF 2.0 file (docs/FORMAT.md "glTF export"): a node hierarchy of groups and
// named parts, repeats as EXT_mesh_gpu_instancing, positions on the package's own grid as
// KHR_mesh_quantization integers (the grid's origin and step folded into the node and instance
// transforms), buffers compressed with meshoptimizer's codecs (EXT_meshopt_compression).

namespace osteon {

struct ExportOptions {
  /// EXT_meshopt_compression: every vertex and index buffer view encoded with meshoptimizer's
  /// vertex and index codecs (normals through the octahedral filter), beside a fallback buffer
  /// without data. False: plain buffer views.
  bool compress = true;
  /// KHR_mesh_quantization: positions as 16-bit integers on the package's grid. False: float
  /// positions (what tools that re-quantise, such as gltfpack, want as input).
  bool quantize = true;
  /// Per-vertex normals (8-bit octahedral when compressed, 8-bit normalised otherwise); the
  /// package's decoded normals. False: none (engines then shade flat).
  bool normals = true;
  /// EXT_mesh_gpu_instancing for meshes drawn by several parts. False: every part its own node
  /// (still sharing the mesh), for engines without the extension.
  bool instancing = true;
};

struct ExportReport {
  uint64_t bytes = 0;      ///< the file's size (for .gltf: the JSON plus the .bin)
  uint64_t bin_bytes = 0;  ///< the binary buffer (the GLB's BIN chunk or the .bin file)
  size_t parts = 0;
  size_t meshes = 0;
  size_t part_nodes = 0;        ///< parts written as nodes of their own
  size_t instancing_nodes = 0;  ///< nodes with EXT_mesh_gpu_instancing
  size_t instances = 0;         ///< parts drawn as instances
  size_t mirrored_instances = 0;
  size_t float_meshes = 0;  ///< meshes whose positions could not stay on a 16-bit grid
  uint64_t triangles = 0;   ///< drawn (decoded components' triangles), over every part
  uint64_t vertices = 0;    ///< stored, over every mesh
  /// The package's bound: the largest instance error_bound (distance of a decoded vertex from
  /// the input it was packed from), in the manifest's unit.
  double error_bound = 0;
  /// Measured: the largest distance between a vertex as a glTF engine places it (the integer
  /// through the node and instance transforms, in double precision) and the package's decoded
  /// vertex (read_package's), in the manifest's unit. Float rounding only, when quantised.
  double max_deviation = 0;
};

/// Writes `package` as glTF 2.0 to `path`: a .glb (one file), or a .gltf and, beside it, the
/// .bin it names (same stem). Each file goes through a temporary file and a rename; the .bin
/// first, and it is removed again when the .gltf cannot be written, so a failed export leaves
/// nothing. Every component is decoded at full resolution (levels of detail are not written).
/// Errors: kInvalidArgument for another extension; kInvalidData for a stream that does not
/// decode (naming chunk and offset) or a manifest whose parts and instances disagree; kIoError
/// when the folder is missing or writing fails (naming the file). O(package vertices).
/// Known approximations: a mesh whose grid spans more than 2^16 steps, whose components lie on
/// different grids, or a part whose instances have different matrices or a matrix that is not
/// a similarity gets float positions (counted in float_meshes; the latter baked in world
/// coordinates).
Status export_gltf(const PackageData& package, const std::string& path,
                   const ExportOptions& options = {}, ExportReport* report = nullptr);

}  // namespace osteon
