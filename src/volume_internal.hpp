// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <zlib.h>

#include "osteon/status.hpp"
#include "osteon/vec.hpp"
#include "osteon/volume.hpp"

// What the label-volume readers share: src/volume_read.cpp (the dispatcher, the voxel stream and
// the conversion of the file's values to dense labels, slab by slab), src/volume_nifti.cpp,
// src/volume_nrrd.cpp and src/volume_labels.cpp (label tables: Caret XML, Slicer segment keys).
//
// Contract of every `read_<format>` function:
// - `path` is hostile: every field is checked before it sizes anything, and each error is
//   `error(code, path, what, field)` naming the header field at fault.
// - It fills `volume->size`, `index_to_world` (osteon's frame: mm, LPS) and `notes`, then hands
//   the voxels to decode_voxels with the labels its header names.

namespace osteon::detail {

// ---- text in headers and label tables --------------------------------------------------------

inline bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r';
}

/// `s` without the spaces, tabs and line ends at either end.
inline std::string_view trim(std::string_view s) {
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return s;
}

// ---- the voxels' type ----------------------------------------------------------------------

enum class VoxelType {
  kUint8,
  kInt8,
  kUint16,
  kInt16,
  kUint32,
  kInt32,
  kUint64,
  kInt64,
  kFloat32,
  kFloat64
};

int voxel_type_bytes(VoxelType type);
/// "uint8", "int16", "float32", ...
const char* voxel_type_name(VoxelType type);

// ---- the voxels' bytes ---------------------------------------------------------------------

enum class DataEncoding {
  kRaw,     ///< the file's bytes as they are
  kGzip,    ///< a gzip stream (an error when the bytes are not gzip)
  kDetect,  ///< gzip when the bytes begin with gzip's magic, else raw (NIfTI: .nii and .nii.gz)
};

/// The decoded bytes of one data file from a byte offset on: plain reads, or zlib's gzread.
/// Memory: zlib's window and a 256 KiB buffer.
class VoxelStream {
 public:
  VoxelStream() = default;
  VoxelStream(const VoxelStream&) = delete;
  VoxelStream& operator=(const VoxelStream&) = delete;
  ~VoxelStream();

  /// Opens the regular file `path`, its stream beginning at file byte `file_offset`. `field` is
  /// the header field that named the encoding, for messages. Errors: kIoError when the file
  /// cannot be opened; kInvalidData for an offset past its end or kGzip on bytes that are not.
  Status open(const std::string& path, uint64_t file_offset, DataEncoding encoding,
              const std::string& source, const std::string& field);
  /// Reads and discards `bytes` of the decoded stream (error, naming `field`, if it ends first).
  Status skip(uint64_t bytes, const std::string& field);
  /// Makes the current position the voxels' start, where restart() comes back to.
  void mark_start() { start_ = position_; }
  /// Reads up to `bytes`; `*got` < `bytes` only where the stream ends. Errors: corrupt gzip.
  Status read(uint8_t* out, size_t bytes, size_t* got);
  /// Back to the voxels' start (gzip: decodes again from the stream's beginning).
  Status restart();

  bool gzip() const { return gz_ != nullptr; }
  uint64_t file_size() const { return file_size_; }
  /// The most decoded bytes the stream can hold from the voxels' start: the file's bytes left
  /// (raw), or deflate's limit of 1032 decoded bytes a compressed byte (gzip).
  uint64_t max_bytes() const;
  /// gzip's trailer, when the file ends with the stream: the decoded size modulo 2^32.
  std::optional<uint32_t> gzip_size_mod32() const { return isize_; }

 private:
  void close();

  int fd_ = -1;
  gzFile gz_ = nullptr;
  std::string source_;
  uint64_t file_size_ = 0;
  uint64_t file_offset_ = 0;  ///< where the stream begins in the file
  uint64_t position_ = 0;     ///< decoded bytes read so far
  uint64_t start_ = 0;        ///< decoded offset of the first voxel
  std::optional<uint32_t> isize_;
};

// ---- from the file's values to dense labels ------------------------------------------------

/// How the voxels lie in the stream, as the header declares them.
struct VoxelLayout {
  std::array<uint32_t, 3> size{0, 0, 0};
  VoxelType type = VoxelType::kUint8;
  bool big_endian = false;
  /// Values a voxel holds in the stream, consecutively (an NRRD's leading list axis); 1: one.
  uint32_t components = 1;
  /// Slicer layers: component l of a voxel is layer l, and layer_labels[l][v] is the label
  /// value that file value v of layer l stands for (0: none). Empty: component 0 alone is read.
  std::vector<std::vector<uint32_t>> layer_labels;
  /// Intensity = value * slope + intercept, for thresholding only (NIfTI's scl_slope/scl_inter).
  double slope = 1;
  double intercept = 0;
  /// Decoded bytes the header declares from the first voxel on (every volume of a 4-D file):
  /// checked against what the file can hold before anything is allocated.
  uint64_t declared_bytes = 0;
  /// The decoded size of the whole stream (header bytes before the voxels included), when known:
  /// matched against gzip's trailer to reserve the labels at once instead of growing them.
  uint64_t stream_bytes = 0;
  /// The header field that declares the grid, for messages ("dim", "sizes").
  std::string size_field = "dim";
};

/// Reads the first volume of `layout` from `stream` (positioned at the first voxel, start
/// marked) into volume->voxels, values and table, slab by slab (about 4 MiB of the file's bytes
/// at a time): memory is the dense labels plus one slab. `named` are the labels the header
/// names (value > 0, unique). A volume that holds anything but labels (a negative value, a float
/// that is not an integer, a value over 2^32 - 1, or over 4096 distinct values when nothing is
/// named) is an intensity volume: refused without options.threshold, else read again from the
/// start as label 1, "bone", where value * slope + intercept >= threshold.
Status decode_voxels(VoxelStream& stream, const VoxelLayout& layout,
                     const std::vector<VolumeLabel>& named, const VolumeReadOptions& options,
                     const std::string& source, LabelVolume* volume);

/// Checks a voxel-to-world transform: finite, no zero-length axis ("zero voxel size"), not
/// singular. `field` names the header field it came from.
Status check_index_to_world(const Mat4& m, const std::string& source, const std::string& field);

/// `text` in double quotes for a message: control bytes as '?', cut to 60 bytes ("...").
std::string in_quotes(std::string_view text);

/// Checked product of a grid's extents; false on overflow of 64 bits.
bool checked_multiply(uint64_t a, uint64_t b, uint64_t* out);

// ---- the formats ---------------------------------------------------------------------------

Status read_nifti(const std::string& path, const VolumeReadOptions& options, LabelVolume* volume);
Status read_nrrd(const std::string& path, const VolumeReadOptions& options, LabelVolume* volume);

// ---- label tables (src/volume_labels.cpp) --------------------------------------------------

/// The labels of the first Caret/Workbench XML <LabelTable> in `xml` (a NIfTI extension's
/// bytes): `<Label Key="1" Red="0" Green="1" Blue="0" Alpha="1"><![CDATA[spleen]]></Label>`,
/// names as CDATA or text with the five XML entities and character references decoded, sorted
/// by value; Key 0 (the background) is left out. Nothing when `xml` holds no <LabelTable>.
/// Errors (kInvalidData, naming `field`): a malformed <Label>, a Key that is not an integer, a
/// colour outside 0..1, one Key twice, one name for two Keys.
Result<std::vector<VolumeLabel>> parse_caret_label_table(std::string_view xml,
                                                         const std::string& source,
                                                         const std::string& field);

/// One segment of a Slicer segmentation (.seg.nrrd): `SegmentN_Name:=`, `SegmentN_Color:=r g b`
/// (0..1), `SegmentN_LabelValue:=` (default 1) and `SegmentN_Layer:=` (default: N in a
/// segmentation of one layer per segment, else 0).
struct SlicerSegment {
  int index = 0;      ///< N of SegmentN_
  VolumeLabel label;  ///< label.value: the segment's LabelValue in its layer
  uint32_t layer = 0;
};

/// The segments named by NRRD key/value pairs, by N. `layers`: the layers the file holds
/// (its list axis; 1 for a 3-D file). Errors (kInvalidData, naming the key): a value that does
/// not parse, a colour outside 0..1, a layer out of range, two segments with one name or one
/// (layer, label value).
Result<std::vector<SlicerSegment>> parse_slicer_segments(
    const std::vector<std::pair<std::string, std::string>>& key_values, uint32_t layers,
    const std::string& source);

/// Error when two labels share a name; `field(i)` names where label i came from.
Status check_unique_names(const std::vector<VolumeLabel>& labels,
                          const std::vector<std::string>& fields, const std::string& source);

}  // namespace osteon::detail
