// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "io_internal.hpp"
#include "osteon/io.hpp"
#include "osteon/package.hpp"
#include "osteon/repeats.hpp"
#include "osteon/volume.hpp"

// The one entry point for "any input": above the mesh readers (src/io*.cpp), the label-volume
// readers (src/volume_*.cpp) and the package module (src/package), so that none depends on
// another. A package folder reads as the parts the viewer draws; a label volume as one surface
// per label; everything else goes to the mesh readers.

namespace osteon {

namespace {

/// Pieces of a thresholded CT smaller than this are noise (a few voxels of calcification or
/// beam-hardening), not bones.
constexpr size_t kSmallestBonePiece = 64;

/// The shortest of the voxel's three sides, in mm.
double smallest_voxel_side(const LabelVolume& volume) {
  double side = 0;
  for (int axis = 0; axis < 3; ++axis) {
    const double* column = &volume.index_to_world[4 * axis];
    const double length = std::sqrt(column[0] * column[0] + column[1] * column[1] +
                                    column[2] * column[2]);
    side = axis == 0 ? length : std::min(side, length);
  }
  return side;
}

/// A label volume's surfaces as parts, one per label (or, for a thresholded CT, one per connected
/// piece).
Result<Scene> read_volume_parts(const std::string& path, const ReadOptions& options) {
  VolumeReadOptions volume_options;
  volume_options.threshold = options.threshold;
  OSTEON_ASSIGN_OR_RETURN(LabelVolume volume, read_volume(path, volume_options));
  SurfaceOptions surface_options;
  OSTEON_ASSIGN_OR_RETURN(surface_options.labels, select_labels(volume, options.labels));
  surface_options.precision = options.surface_precision;
  if (!(surface_options.precision > 0) && options.surface_precision_voxels > 0) {
    surface_options.precision = options.surface_precision_voxels * smallest_voxel_side(volume);
  }
  surface_options.smoothing_iterations = options.smoothing_iterations;
  OSTEON_ASSIGN_OR_RETURN(std::vector<LabelSurface> surfaces,
                          extract_surfaces(volume, surface_options));
  Scene scene;
  for (LabelSurface& surface : surfaces) {
    Mesh& mesh = surface.mesh;
    mesh.source = path;
    mesh.label = surface.value;
    mesh.unit = Unit::kMillimetre;
    mesh.unit_source = UnitSource::kUser;  // the volume's header says so
    mesh.stored_vertices = mesh.positions.size();
    for (const VolumeLabel& label : volume.table) {
      if (label.value == surface.value && label.has_color && !mesh.has_color) {
        mesh.has_color = true;
        mesh.color = label.color;
      }
    }
    if (!options.threshold) {
      scene.parts.push_back(std::move(mesh));
      continue;
    }
    for (Mesh& piece : split_connected(mesh)) {
      if (piece.triangle_count() >= kSmallestBonePiece) scene.parts.push_back(std::move(piece));
    }
  }
  if (scene.parts.empty()) {
    return error(ErrorCode::kInvalidData, path,
                 options.threshold ? "no voxel reaches the threshold" : "no label to extract");
  }
  if (options.unit != Unit::kUnknown) detail::assign_unit(options, &scene);
  return scene;
}

}  // namespace

Result<Scene> read_path(const std::string& path, const ReadOptions& options) {
  if (is_volume_path(path)) return read_volume_parts(path, options);
  if (!is_package(path)) return read_meshes(path, options);
  OSTEON_ASSIGN_OR_RETURN(Scene scene, read_package(path, options.package_level));
  // The manifest's unit stands unless the caller gives one or it is unknown.
  const bool unit_known = !scene.parts.empty() && scene.parts.front().unit != Unit::kUnknown;
  if (options.unit != Unit::kUnknown || !unit_known) detail::assign_unit(options, &scene);
  return scene;
}

}  // namespace osteon
