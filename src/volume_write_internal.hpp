// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "osteon/status.hpp"
#include "osteon/vec.hpp"
#include "osteon/volume.hpp"

// The one NIfTI-1 label writer behind voxelize and write_label_volume (src/volume_write.cpp):
// the header built by libnifti, the label table as a Caret XML extension, the voxels streamed
// slab by slab through zlib into a temporary file that is renamed over the target at the end.

struct gzFile_s;

namespace osteon::detail {

/// What the writer needs to know before the first voxel.
struct LabelVolumeLayout {
  std::array<uint32_t, 3> size{0, 0, 0};
  Mat4 index_to_world = kIdentityMatrix;  ///< osteon's frame (LPS, mm); written as RAS+
  int bytes_per_voxel = 1;                ///< 1 (uint8), 2 (uint16) or 4 (uint32), host order
  /// The Caret XML label table (value, name, colour; a label without colour gets a palette's);
  /// empty: no extension.
  std::vector<VolumeLabel> labels;
};

/// True for a path osteon writes a label volume to: .nii or .nii.gz (any case).
bool is_nifti_write_path(const std::string& path);

/// The Caret XML label table TotalSegmentator writes into its code-0 extension.
std::string caret_label_table(const std::vector<VolumeLabel>& labels);

/// A NIfTI-1 single-file label volume (.nii plain, .nii.gz gzip) written through a temporary file
/// beside the target: open() writes the header, write() takes the voxels in file order (x
/// fastest, then y, then z), commit() checks that every voxel came, syncs and renames. Destroyed
/// before commit(), it removes the temporary, so a failure never leaves a half-written file.
class NiftiLabelWriter {
 public:
  NiftiLabelWriter() = default;
  NiftiLabelWriter(const NiftiLabelWriter&) = delete;
  NiftiLabelWriter& operator=(const NiftiLabelWriter&) = delete;
  ~NiftiLabelWriter();

  /// Errors: kInvalidArgument for another extension, an empty grid or one NIfTI-1 cannot hold
  /// (over 32767 voxels a side), a singular or non-finite transform; kIoError when the temporary
  /// file cannot be created (a missing folder) or the header cannot be written.
  Status open(const std::string& path, const LabelVolumeLayout& layout);
  /// Appends `bytes` bytes of voxels. Errors: kIoError.
  Status write(const uint8_t* data, size_t bytes);
  /// Errors: kIoError (a short volume, a failed write, sync or rename).
  Status commit();

  /// z-slices per slab for about `budget` bytes a slab (at least one).
  static uint32_t slab_slices(const LabelVolumeLayout& layout, size_t budget = size_t{16} << 20);

 private:
  void discard();

  std::string path_;
  std::string temp_;
  int fd_ = -1;
  gzFile_s* gz_ = nullptr;
  uint64_t expected_ = 0;
  uint64_t written_ = 0;
};

}  // namespace osteon::detail
