// SPDX-License-Identifier: Apache-2.0
#include <fcntl.h>
#include <nifti2_io.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "osteon/volume.hpp"
#include "volume_write_internal.hpp"

// Based on: the NIfTI-1 standard (nifti1.h: the 348-byte header, the 4-byte extender, extensions
// of esize bytes, a multiple of 16, each an esize, an ecode and the data; voxels from vox_offset),
// and TotalSegmentator's nifti_ext_header.py for the label table: a code-0 extension holding
// Connectome Workbench's Caret XML, colours as fractions 0..1, names in CDATA.
//
// libnifti builds the header (nifti_make_new_nim, nifti_mat44_to_quatern, nifti_add_extension,
// nifti_convert_nim2nhdr), so every field is filled as the reference library fills it; the bytes
// then go through zlib's gzwrite (gzip, or 'T' for a plain .nii) so that the voxels can stream in
// slab by slab, which nifti_image_write cannot do: it wants the whole volume in memory.

namespace osteon {

// libnifti writes the header in the host's byte order and the voxels are copied as they are in
// memory, little-endian; the two agree only on a little-endian host.
static_assert(std::endian::native == std::endian::little, "the NIfTI writer assumes little-endian");

namespace detail {

namespace {

/// gzip level for .nii.gz: zlib's default. On the BodyParts3D skeleton at 0.5 mm (2.1 G voxels)
/// level 6 writes 6.5 MB where level 1 writes 17 MB, for about 3 s more.
constexpr int kGzipLevel = 6;

std::string errno_text(int code) {
  return std::generic_category().message(code);
}

bool ends_with_nocase(const std::string& text, const std::string& suffix) {
  if (text.size() < suffix.size()) return false;
  for (size_t i = 0; i < suffix.size(); ++i) {
    char c = text[text.size() - suffix.size() + i];
    if (c >= 'A' && c <= 'Z') c = char(c - 'A' + 'a');
    if (c != suffix[i]) return false;
  }
  return true;
}

/// A palette for labels the caller gives no colour: TotalSegmentator's first twelve.
Vec3 palette_color(uint32_t value) {
  static const float kPalette[12][3] = {{1.0f, 0.0f, 0.0f}, {0.0f, 1.0f, 0.0f}, {0.0f, 0.0f, 1.0f},
                                        {1.0f, 1.0f, 0.0f}, {1.0f, 0.0f, 1.0f}, {0.0f, 1.0f, 1.0f},
                                        {1.0f, 0.5f, 0.0f}, {1.0f, 0.0f, 0.5f}, {0.5f, 1.0f, 0.5f},
                                        {0.5f, 0.5f, 1.0f}, {1.0f, 0.5f, 0.5f}, {0.5f, 0.0f, 1.0f}};
  const float* c = kPalette[value % 12];
  return {c[0], c[1], c[2]};
}

std::string format_fraction(float value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.6g", double(std::clamp(value, 0.0f, 1.0f)));
  return text;
}

/// `name` inside CDATA: a "]]>" in it is split across two sections.
std::string cdata(const std::string& name) {
  std::string out = "<![CDATA[";
  size_t start = 0;
  for (size_t at = name.find("]]>"); at != std::string::npos; at = name.find("]]>", start)) {
    out += name.substr(start, at + 2 - start) + "]]><![CDATA[";
    start = at + 2;
  }
  return out + name.substr(start) + "]]>";
}

struct NiftiImageFree {
  void operator()(nifti_image* image) const { nifti_image_free(image); }
};
using NiftiImagePtr = std::unique_ptr<nifti_image, NiftiImageFree>;

/// The header, extender and extensions as they go into the file.
Result<std::vector<uint8_t>> header_bytes(const std::string& path,
                                          const LabelVolumeLayout& layout) {
  auto bad = [&](const std::string& what) {
    return error(ErrorCode::kInvalidArgument, path, what);
  };
  int datatype = layout.bytes_per_voxel == 1   ? DT_UINT8
                 : layout.bytes_per_voxel == 2 ? DT_UINT16
                                               : DT_UINT32;
  const int64_t dims[8] = {
      3, int64_t(layout.size[0]), int64_t(layout.size[1]), int64_t(layout.size[2]), 1, 1, 1, 1};
  NiftiImagePtr nim(nifti_make_new_nim(dims, datatype, 0));
  if (!nim) return bad("libnifti cannot make a header for this grid");

  // osteon's frame is LPS; NIfTI's world is RAS+: x and y change sign.
  const Mat4& m = layout.index_to_world;
  nifti_dmat44 ras;
  for (int r = 0; r < 4; ++r) {
    double sign = r < 2 ? -1.0 : 1.0;
    for (int c = 0; c < 4; ++c) ras.m[r][c] = r < 3 ? sign * m[4 * c + r] : double(c == 3);
  }
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) {
      if (!std::isfinite(ras.m[r][c])) return bad("the voxel-to-world transform is not finite");
    }
  }
  if (!(std::fabs(determinant3(m)) > 0)) return bad("the voxel-to-world transform is singular");
  nim->sto_xyz = ras;
  nim->sto_ijk = nifti_dmat44_inverse(ras);
  nim->sform_code = NIFTI_XFORM_SCANNER_ANAT;
  double dx = 0, dy = 0, dz = 0;
  nifti_dmat44_to_quatern(ras, &nim->quatern_b, &nim->quatern_c, &nim->quatern_d, &nim->qoffset_x,
                          &nim->qoffset_y, &nim->qoffset_z, &dx, &dy, &dz, &nim->qfac);
  nim->qto_xyz =
      nifti_quatern_to_dmat44(nim->quatern_b, nim->quatern_c, nim->quatern_d, nim->qoffset_x,
                              nim->qoffset_y, nim->qoffset_z, dx, dy, dz, nim->qfac);
  nim->qto_ijk = nifti_dmat44_inverse(nim->qto_xyz);
  nim->qform_code = NIFTI_XFORM_SCANNER_ANAT;
  nim->dx = nim->pixdim[1] = dx;
  nim->dy = nim->pixdim[2] = dy;
  nim->dz = nim->pixdim[3] = dz;
  nim->xyz_units = NIFTI_UNITS_MM;
  nim->intent_code = NIFTI_INTENT_LABEL;
  uint32_t max_value = 0;
  for (const VolumeLabel& label : layout.labels) max_value = std::max(max_value, label.value);
  nim->cal_min = 0;
  nim->cal_max = double(max_value);
  std::snprintf(nim->descrip, sizeof(nim->descrip), "osteon label volume");

  if (!layout.labels.empty()) {
    std::string xml = caret_label_table(layout.labels);
    if (xml.size() > size_t{1} << 30) return bad("the label table is too large for a header");
    if (nifti_add_extension(nim.get(), xml.data(), int(xml.size()), NIFTI_ECODE_IGNORE) != 0)
      return bad("libnifti cannot add the label table extension");
  }
  size_t offset = sizeof(nifti_1_header) + 4;
  for (int e = 0; e < nim->num_ext; ++e) offset += size_t(nim->ext_list[e].esize);
  offset = (offset + 15) / 16 * 16;
  nim->iname_offset = int64_t(offset);

  nifti_1_header header{};
  if (nifti_convert_nim2n1hdr(nim.get(), &header) != 0) {
    return bad("libnifti cannot write a NIfTI-1 header for this grid");
  }
  header.vox_offset = float(offset);
  std::memcpy(header.magic, "n+1\0", 4);

  std::vector<uint8_t> bytes(offset, 0);
  std::memcpy(bytes.data(), &header, sizeof(header));
  uint8_t* p = bytes.data() + sizeof(header);
  p[0] = nim->num_ext > 0 ? 1 : 0;  // the extender
  p += 4;
  for (int e = 0; e < nim->num_ext; ++e) {
    const nifti1_extension& ext = nim->ext_list[e];
    int32_t fields[2] = {ext.esize, ext.ecode};
    std::memcpy(p, fields, 8);
    std::memcpy(p + 8, ext.edata, size_t(ext.esize) - 8);
    p += ext.esize;
  }
  return bytes;
}

}  // namespace

bool is_nifti_write_path(const std::string& path) {
  return ends_with_nocase(path, ".nii") || ends_with_nocase(path, ".nii.gz");
}

std::string caret_label_table(const std::vector<VolumeLabel>& labels) {
  std::string xml =
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<CaretExtension>\n"
      "  <VolumeInformation Index=\"0\">\n    <LabelTable>\n";
  for (const VolumeLabel& label : labels) {
    Vec3 c = label.has_color ? label.color : palette_color(label.value);
    xml += "      <Label Key=\"" + std::to_string(label.value) + "\" Red=\"" +
           format_fraction(c.x) + "\" Green=\"" + format_fraction(c.y) + "\" Blue=\"" +
           format_fraction(c.z) + "\" Alpha=\"1\">" + cdata(label.name) + "</Label>\n";
  }
  xml +=
      "    </LabelTable>\n    <VolumeType><![CDATA[Label]]></VolumeType>\n"
      "  </VolumeInformation>\n</CaretExtension>\n";
  return xml;
}

NiftiLabelWriter::~NiftiLabelWriter() {
  discard();
}

void NiftiLabelWriter::discard() {
  if (gz_) gzclose_w(gz_);
  gz_ = nullptr;
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  if (!temp_.empty()) ::unlink(temp_.c_str());
  temp_.clear();
}

uint32_t NiftiLabelWriter::slab_slices(const LabelVolumeLayout& layout, size_t budget) {
  uint64_t slice = uint64_t{layout.size[0]} * layout.size[1] * uint64_t(layout.bytes_per_voxel);
  uint64_t slices = slice > 0 ? budget / slice : 1;
  return uint32_t(std::clamp<uint64_t>(slices, 1, std::max<uint32_t>(layout.size[2], 1)));
}

Status NiftiLabelWriter::open(const std::string& path, const LabelVolumeLayout& layout) {
  discard();
  path_ = path;
  if (!is_nifti_write_path(path))
    return error(ErrorCode::kInvalidArgument, path, "label volumes are written as .nii or .nii.gz");
  for (uint32_t n : layout.size) {
    if (n == 0) return error(ErrorCode::kInvalidArgument, path, "the grid is empty");
    if (n > 32767)
      return error(ErrorCode::kInvalidArgument, path,
                   std::to_string(n) + " voxels a side: NIfTI-1 holds at most 32767");
  }
  if (layout.bytes_per_voxel != 1 && layout.bytes_per_voxel != 2 && layout.bytes_per_voxel != 4)
    return error(ErrorCode::kInvalidArgument, path, "labels take 1, 2 or 4 bytes a voxel");
  OSTEON_ASSIGN_OR_RETURN(std::vector<uint8_t> header, header_bytes(path, layout));

  static std::atomic<uint64_t> counter{0};
  // O_EXCL: never write into a file someone else made under the same name.
  for (int attempt = 0; attempt < 16 && fd_ < 0; ++attempt) {
    temp_ = path + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
    fd_ = ::open(temp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd_ < 0 && errno != EEXIST) break;
  }
  if (fd_ < 0) {
    int code = errno;
    temp_.clear();
    return error(ErrorCode::kIoError, path,
                 "cannot create a temporary file beside it: " + errno_text(code));
  }
  // zlib closes the descriptor it is given; ours stays open for fsync.
  int gz_fd = ::dup(fd_);
  bool gzip = ends_with_nocase(path, ".gz");
  std::string mode = gzip ? "wb" + std::to_string(kGzipLevel) : "wbT";
  gz_ = gz_fd >= 0 ? gzdopen(gz_fd, mode.c_str()) : nullptr;
  if (!gz_) {
    int code = errno;
    if (gz_fd >= 0) ::close(gz_fd);
    discard();
    return error(ErrorCode::kIoError, path, "cannot start writing: " + errno_text(code));
  }
  gzbuffer(gz_, 1 << 20);
  expected_ =
      uint64_t{layout.size[0]} * layout.size[1] * layout.size[2] * uint64_t(layout.bytes_per_voxel);
  written_ = 0;
  OSTEON_RETURN_IF_ERROR(write(header.data(), header.size()));
  written_ = 0;  // commit() counts the voxels' bytes only
  return Status();
}

Status NiftiLabelWriter::write(const uint8_t* data, size_t bytes) {
  if (!gz_) return error(ErrorCode::kIoError, path_, "the file is not open");
  while (bytes > 0) {
    unsigned n = unsigned(std::min<size_t>(bytes, size_t{1} << 30));
    if (gzwrite(gz_, data, n) != int(n)) {
      int code = errno;
      int gz_code = 0;
      const char* gz_message = gzerror(gz_, &gz_code);
      std::string why = gz_code == Z_ERRNO ? errno_text(code) : std::string(gz_message);
      discard();
      return error(ErrorCode::kIoError, path_, "cannot write: " + why);
    }
    data += n;
    bytes -= n;
    written_ += n;
  }
  return Status();
}

Status NiftiLabelWriter::commit() {
  if (!gz_) return error(ErrorCode::kIoError, path_, "the file is not open");
  if (written_ != expected_) {
    discard();
    return error(ErrorCode::kIoError, path_,
                 std::to_string(written_) + " voxel bytes written of " + std::to_string(expected_));
  }
  int closed = gzclose_w(gz_);
  gz_ = nullptr;
  int code = errno;
  if (closed != Z_OK) {
    discard();
    return error(ErrorCode::kIoError, path_,
                 "cannot write: " + (closed == Z_ERRNO ? errno_text(code) : "zlib error"));
  }
  if (::fsync(fd_) != 0 && errno != EINVAL) {
    code = errno;
    discard();
    return error(ErrorCode::kIoError, path_, "cannot write: " + errno_text(code));
  }
  if (::close(fd_) != 0) {
    code = errno;
    fd_ = -1;
    discard();
    return error(ErrorCode::kIoError, path_, "cannot write: " + errno_text(code));
  }
  fd_ = -1;
  if (std::rename(temp_.c_str(), path_.c_str()) != 0) {
    code = errno;
    discard();
    return error(ErrorCode::kIoError, path_, "cannot replace it: " + errno_text(code));
  }
  temp_.clear();
  return Status();
}

}  // namespace detail

namespace {

/// The label table to write for `volume`: its own, plus "label <v>" for a value it does not name.
std::vector<VolumeLabel> table_for(const LabelVolume& volume) {
  std::vector<VolumeLabel> labels;
  for (const VolumeLabel& label : volume.table) {
    if (label.value > 0) labels.push_back(label);
  }
  std::vector<uint32_t> named;
  for (const VolumeLabel& label : labels) named.push_back(label.value);
  std::sort(named.begin(), named.end());
  for (size_t d = 1; d < volume.values.size(); ++d) {
    uint32_t value = volume.values[d];
    if (value > 0 && !std::binary_search(named.begin(), named.end(), value)) {
      VolumeLabel label;
      label.value = value;
      label.name = "label " + std::to_string(value);
      labels.push_back(label);
    }
  }
  std::stable_sort(labels.begin(), labels.end(),
                   [](const VolumeLabel& a, const VolumeLabel& b) { return a.value < b.value; });
  return labels;
}

}  // namespace

Status write_label_volume(const LabelVolume& volume, const std::string& path) {
  auto bad = [&](const std::string& what) {
    return error(ErrorCode::kInvalidArgument, path, what);
  };
  if (!detail::is_nifti_write_path(path))
    return bad("label volumes are written as .nii or .nii.gz");
  if (volume.bytes_per_voxel != 1 && volume.bytes_per_voxel != 2)
    return bad("bytes_per_voxel is " + std::to_string(volume.bytes_per_voxel) + ", not 1 or 2");
  const size_t count = volume.voxel_count();
  if (volume.voxels.size() != count * size_t(volume.bytes_per_voxel))
    return bad(std::to_string(volume.voxels.size()) + " voxel bytes for " + std::to_string(count) +
               " voxels");
  if (volume.values.empty() || volume.values[0] != 0) return bad("values[0] must be 0");
  uint32_t max_value = 0;
  for (uint32_t v : volume.values) max_value = std::max(max_value, v);
  for (size_t i = 0; i < count; ++i) {
    if (volume.id(i) >= volume.values.size())
      return bad("voxel " + std::to_string(i) + " has dense id " + std::to_string(volume.id(i)) +
                 " of " + std::to_string(volume.values.size()));
  }

  detail::LabelVolumeLayout layout;
  layout.size = volume.size;
  layout.index_to_world = volume.index_to_world;
  layout.bytes_per_voxel = max_value <= 0xff ? 1 : max_value <= 0xffff ? 2 : 4;
  layout.labels = table_for(volume);
  detail::NiftiLabelWriter out;
  OSTEON_RETURN_IF_ERROR(out.open(path, layout));

  const uint32_t slices = detail::NiftiLabelWriter::slab_slices(layout);
  const size_t slice_voxels = size_t{volume.size[0]} * volume.size[1];
  std::vector<uint8_t> slab;
  for (uint32_t k0 = 0; k0 < volume.size[2]; k0 += slices) {
    uint32_t k1 = std::min(volume.size[2], k0 + slices);
    size_t first = slice_voxels * k0, n = slice_voxels * (k1 - k0);
    slab.resize(n * size_t(layout.bytes_per_voxel));
    for (size_t i = 0; i < n; ++i) {
      uint32_t value = volume.values[volume.id(first + i)];
      std::memcpy(slab.data() + i * size_t(layout.bytes_per_voxel), &value,
                  size_t(layout.bytes_per_voxel));
    }
    OSTEON_RETURN_IF_ERROR(out.write(slab.data(), slab.size()));
  }
  return out.commit();
}

}  // namespace osteon
