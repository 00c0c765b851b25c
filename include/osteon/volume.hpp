// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "osteon/mesh.hpp"
#include "osteon/status.hpp"
#include "osteon/vec.hpp"

// Label volumes: what CT segmenters write (TotalSegmentator's NIfTI, 3D Slicer's .seg.nrrd), read
// as one integer label per voxel on a grid placed in world space, with the labels' names and
// colours; their bone surfaces (extract_surfaces); and the way back, meshes to a label volume
// (voxelize, write_label_volume). docs/DESIGN.md "Label volumes" says why each choice was made.

namespace osteon {

/// A label's name and colour, as the volume's own header (a NIfTI Caret XML label table, Slicer's
/// segment keys) or a names file gives them.
struct VolumeLabel {
  uint32_t value = 0;  ///< the label value stored in the voxels (> 0)
  std::string name;
  bool has_color = false;
  Vec3 color{0, 0, 0};  ///< sRGB, each 0..1
  uint64_t voxels = 0;  ///< voxels of this label in the volume; 0: named but absent
};

/// One integer label per voxel; 0 is background. Voxel (i, j, k) is at index i + size[0] * (j +
/// size[1] * k) of `labels`, and its centre at transform_point(index_to_world, {i, j, k}).
///
/// World coordinates are osteon's frame, the one the mesh skeletons come in: millimetres,
/// +x to the patient's left, +y posterior, +z superior (LPS, as DICOM). A NIfTI sform/qform
/// (RAS+) has x and y negated on reading; an NRRD's space (RAS or LPS) is converted likewise.
struct LabelVolume {
  std::array<uint32_t, 3> size{0, 0, 0};
  Mat4 index_to_world = kIdentityMatrix;
  /// The voxels' labels as dense ids: 0 background, id d > 0 stands for label value
  /// values[d]. One byte a voxel while at most 255 labels are present, else two.
  std::vector<uint8_t> voxels;
  int bytes_per_voxel = 1;  ///< 1 or 2
  std::vector<uint32_t> values{0};  ///< dense id -> label value; values[0] == 0
  /// One entry per label value present in the voxels or named by the file, sorted by value:
  /// names and colours where the file gives them, and the voxel count. (TotalSegmentator's table
  /// names all 117 classes; a volume holds a few of them.)
  std::vector<VolumeLabel> table;
  std::string source;  ///< the file it was read from
  /// What the reader decided that the user should know, one sentence each ("4-D volume: the
  /// first of 3 volumes is read").
  std::vector<std::string> notes;

  size_t voxel_count() const { return size_t{size[0]} * size[1] * size[2]; }
  /// The dense id of voxel `index`.
  uint32_t id(size_t index) const {
    return bytes_per_voxel == 1 ? voxels[index]
                                : uint32_t(voxels[2 * index]) | uint32_t(voxels[2 * index + 1]) << 8;
  }
};

struct VolumeReadOptions {
  /// An intensity volume (a CT in Hounsfield units) becomes a label volume of one label,
  /// "bone", where the value is at least this (e.g. 250). Unset: the volume must hold labels; an
  /// intensity volume is refused with an error that says so.
  std::optional<double> threshold;
  /// Refuse volumes whose voxels would take more than this many bytes in memory.
  uint64_t max_voxel_bytes = uint64_t{8} << 30;
};

/// True when `path` names a volume file osteon reads: .nii, .nii.gz, .nrrd, .nhdr (.seg.nrrd is
/// an .nrrd).
bool is_volume_path(const std::string& path);

/// Reads a NIfTI-1 or NIfTI-2 (.nii, .nii.gz) or NRRD (.nrrd, .nhdr with its detached data file,
/// raw or gzip) label volume of any integer type, streaming the voxels slab by slab (memory: the
/// labels' bytes plus one slab). Names and colours come from the header: a NIfTI extension of
/// code 0 holding a Caret/Workbench XML <LabelTable>, or Slicer's SegmentN_Name / _Color /
/// _LabelValue / _Layer keys.
/// Errors (naming the file and the field): kIoError for a missing file; kInvalidData for
/// truncated or corrupt data, dimensions that do not match the data, zero, negative or NaN voxel
/// sizes, a singular or NaN transform, float labels that are not integers, an intensity volume
/// without options.threshold, a detached data file outside the header's folder, a label table
/// giving two labels one name or one label two entries; kUnsupported for what osteon does not
/// read.
Result<LabelVolume> read_volume(const std::string& path, const VolumeReadOptions& options = {});

// ---- choosing labels (src/label_select.cpp) ----------------------------------------------------

/// True when a label's name names a bone (or the costal cartilages): one of its words starts with
/// a bone word (vertebra, rib, sternum, costal, clavic, scapul, skull, humer, hip, sacrum, femur,
/// tibia, ...) and none names soft tissue (cord, artery, vein, muscle, ...). Works for
/// TotalSegmentator's class names ("vertebrae_T11", "rib_left_7") and Slicer's ("Left femur").
bool is_bone_name(const std::string& name);

/// The label values (sorted) that `selection` picks: each item a label value, a label name
/// (case-insensitive), or the preset "bones" (every present label is_bone_name accepts); empty:
/// every label present. Errors (kInvalidArgument, naming the item): a value or name that is not
/// present, a name no label has, "bones" finding no bone.
Result<std::vector<uint32_t>> select_labels(const LabelVolume& volume,
                                            const std::vector<std::string>& selection);

// ---- surfaces of a label volume (src/surface_nets.cpp, src/simplify_surfaces.cpp) -----------

struct SurfaceOptions {
  /// The label values to extract; empty: every label present.
  std::vector<uint32_t> labels;
  /// Constrained smoothing passes (Taubin's two steps, which do not shrink the surface): each
  /// vertex moves towards the mean of its neighbours but stays inside its cell (the cube between
  /// 8 voxel centres), and one on a line where three regions meet moves only along it, so it never
  /// leaves the voxels around the label's boundary. 0: the raw, stair-stepped net.
  int smoothing_iterations = 16;
  /// > 0: simplify each surface (meshoptimizer, with the lines where three regions meet locked,
  /// so touching labels keep one shared boundary) until the next collapse would exceed this
  /// distance, in mm. 0: no simplification.
  double precision = 0;
  /// Worker threads; 0: every core.
  int threads = 0;
};

/// One label's surface.
struct LabelSurface {
  uint32_t value = 0;  ///< the label value
  Mesh mesh;           ///< closed, oriented outwards, manifold; named after the label
  uint64_t triangles_extracted = 0;  ///< before simplification
};

/// The surface of every selected label of `volume`, by Surface Nets (Frisken 2022) with
/// constrained smoothing: one vertex per cell the label's boundary crosses, split where the
/// label's surface would otherwise touch itself, so each surface is watertight, oriented and
/// manifold; two labels that touch share their boundary vertex for vertex (no gap, no overlap);
/// every vertex stays within one voxel of the label's boundary. Meshes are in world coordinates
/// (mm), named after the label table (else "label <value>"); read_path adds the table's colour
/// and the label value (Mesh::color, Mesh::label).
/// Errors: kInvalidArgument for a label value not present. O(voxels + surface).
Result<std::vector<LabelSurface>> extract_surfaces(const LabelVolume& volume,
                                                   const SurfaceOptions& options = {});

/// The voxel faces between label `value` and everything else (background, other labels, outside
/// the grid), two triangles a face, facing out, in world coordinates: the exact stair-stepped
/// boundary that extract_surfaces' smooth surfaces are measured against. Vertices are not shared
/// (weld() them for a connected mesh). Errors: kInvalidArgument for a label not present.
/// O(voxels).
Result<Mesh> voxel_faces(const LabelVolume& volume, uint32_t value);

// ---- meshes to a label volume (src/voxelize.cpp, src/volume_write.cpp) ----------------------

struct VoxelizeOptions {
  double voxel = 0.5;  ///< the voxel size in mm (> 0), the same along every axis
  /// Empty voxels around the parts' box on every side.
  uint32_t margin = 2;
  int threads = 0;  ///< 0: every core
};

struct VoxelizeReport {
  std::array<uint32_t, 3> size{0, 0, 0};
  uint64_t voxels = 0;
  uint64_t labelled = 0;  ///< voxels inside some part
  double ms = 0;
};

/// Writes the label volume of `parts` to `path` (.nii or .nii.gz: NIfTI-1, uint8 labels up to
/// 255 parts, else uint16; part k (0-based) is label k + 1, its name in a Caret XML label table in
/// a code-0 header extension; sform in osteon's frame converted to RAS+). A voxel is inside a part
/// by majority vote of ray parity along x, y and z, which holds on open meshes (a hole changes one
/// ray's answer, not three); a voxel inside several parts takes the last. Each part is voxelized
/// in its own box and the file is written slab by slab, through a temporary file and a rename, so
/// memory stays at the parts' boxes plus one slab. Errors: kInvalidArgument for a voxel size that
/// is not positive, a grid over 32767 voxels a side (NIfTI-1 stores 16-bit dimensions) or another
/// extension; kIoError when the file cannot be written (no file is left behind).
Status voxelize(const Scene& parts, const std::string& path, const VoxelizeOptions& options = {},
                VoxelizeReport* report = nullptr);

/// Writes `volume` as NIfTI-1 (.nii or .nii.gz) with its label table, through a temporary file
/// and a rename. Errors: kInvalidArgument for another extension; kIoError when writing fails.
Status write_label_volume(const LabelVolume& volume, const std::string& path);

}  // namespace osteon
