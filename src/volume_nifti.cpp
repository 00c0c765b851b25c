// SPDX-License-Identifier: Apache-2.0
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#if defined(OSTEON_NIFTI2)
#include <nifti2_io.h>
#else
#include <nifti1_io.h>
#endif

#include "volume_internal.hpp"

// Based on: the NIfTI-1 and NIfTI-2 formats (nifti1.h, nifti2.h of the NIfTI Data Format Working
// Group): a one-file .nii (or .nii.gz) of a 348- or 540-byte header, extensions, and the voxels
// from vox_offset; the grid placed by the sform (method 3), else the qform (method 2), else pixdim
// alone (method 1), in RAS+ millimetres unless xyz_units says otherwise.
//
// libnifti (Debian's libnifti2-dev) reads the header and the extensions; the voxels are read here,
// slab by slab, never whole. Its nifti2 library (nifti2_io.h, OSTEON_NIFTI2) reads both versions;
// its niftiio (nifti1_io.h) reads NIfTI-1 only, and a NIfTI-2 file is then refused as unsupported.
// The two export the same function names with different types, so one build links one of them. The
// header is first read alone (nifti_read_header) and checked field by field, before libnifti
// repairs anything (it sets a zero or NaN pixdim to 1 and a NaN quaternion to 0) and before it
// allocates the extensions: the stream must hold vox_offset bytes first, so no extension is larger
// than the file.

namespace osteon::detail {

namespace {

// nifti*_io.h define MSB_FIRST for their own source file only: nim->byteorder of a big-endian file.
constexpr int kMsbFirst = 2;

// libnifti's options and messages are global: one read at a time.
std::mutex& nifti_mutex() {
  static std::mutex mutex;
  return mutex;
}

struct FreeHeader {
  void operator()(void* p) const { std::free(p); }
};
struct FreeImage {
  void operator()(nifti_image* p) const { nifti_image_free(p); }
};

// The header fields as the file holds them (byte-swapped to this machine's order), for both
// versions.
struct RawHeader {
  int version = 1;
  int header_bytes = 348;
  int sizeof_hdr = 0;
  char magic[4] = {};
  bool one_file = true;
  int datatype = 0;
  int64_t dim[8] = {};
  double pixdim[8] = {};
  double vox_offset = 0;
  int qform_code = 0, sform_code = 0;
  double quatern[6] = {};  // b, c, d, qoffset x, y, z
  double srow[3][4] = {};
};

template <class Header>
void copy_fields(const Header& h, RawHeader* out) {
  out->datatype = h.datatype;
  for (int i = 0; i < 8; ++i) {
    out->dim[i] = h.dim[i];
    out->pixdim[i] = h.pixdim[i];
  }
  out->vox_offset = static_cast<double>(h.vox_offset);
  out->qform_code = h.qform_code;
  out->sform_code = h.sform_code;
  const double q[6] = {h.quatern_b, h.quatern_c, h.quatern_d,
                       h.qoffset_x, h.qoffset_y, h.qoffset_z};
  for (int i = 0; i < 6; ++i) out->quatern[i] = q[i];
  for (int c = 0; c < 4; ++c) {
    out->srow[0][c] = h.srow_x[c];
    out->srow[1][c] = h.srow_y[c];
    out->srow[2][c] = h.srow_z[c];
  }
  out->sizeof_hdr = h.sizeof_hdr;
  for (int i = 0; i < 4; ++i) out->magic[i] = h.magic[i];
  out->one_file = h.magic[1] == '+';
}

// sizeof_hdr and magic ("n+1" or "ni1" and a NUL; "n+2", "ni2" for NIfTI-2) as the version says.
bool valid_header(const RawHeader& h) {
  const char digit = h.version == 2 ? '2' : '1';
  return h.sizeof_hdr == h.header_bytes && h.magic[0] == 'n' &&
         (h.magic[1] == '+' || h.magic[1] == 'i') && h.magic[2] == digit && h.magic[3] == '\0';
}

// Reads the header alone, as the file holds it; false when libnifti finds none or it is not
// NIfTI. libnifti's own check is off (it prints what it finds wrong whatever its debug level);
// these checks and check_header's come before anything that would print.
bool read_raw_header(const std::string& path, RawHeader* h) {
#if defined(OSTEON_NIFTI2)
  int version = 0;
  std::unique_ptr<void, FreeHeader> header(nifti_read_header(path.c_str(), &version, 0));
  if (header != nullptr && (version == 1 || version == 2)) {
    // nifti2_io's nifti_read_header leaves a header of the other byte order as it is.
    int32_t sizeof_hdr = 0;
    std::memcpy(&sizeof_hdr, header.get(), 4);
    const int32_t expected = version == 1 ? 348 : 540;
    if (sizeof_hdr != expected &&
        static_cast<int32_t>(__builtin_bswap32(static_cast<uint32_t>(sizeof_hdr))) == expected) {
      swap_nifti_header(header.get(), version);
    }
  }
  if (header != nullptr && version == 1) {
    copy_fields(*static_cast<const nifti_1_header*>(header.get()), h);
    return valid_header(*h);
  }
  if (header != nullptr && version == 2) {
    copy_fields(*static_cast<const nifti_2_header*>(header.get()), h);
    h->version = 2;
    h->header_bytes = 540;
    return valid_header(*h);
  }
  return false;
#else
  int swapped = 0;
  std::unique_ptr<nifti_1_header, FreeHeader> header(nifti_read_header(path.c_str(), &swapped, 0));
  if (header == nullptr) return false;
  copy_fields(*header, h);
  return valid_header(*h);
#endif
}

#if !defined(OSTEON_NIFTI2)
// sizeof_hdr of NIfTI-2, 540, in either byte order.
bool nifti2_size(const uint8_t* first) {
  const uint32_t little = uint32_t{first[0]} | uint32_t{first[1]} << 8 | uint32_t{first[2]} << 16 |
                          uint32_t{first[3]} << 24;
  return little == 540 || __builtin_bswap32(little) == 540;
}
#endif

// Why libnifti found no header: the stream's own error (truncated or corrupt gzip), or bytes
// that are not NIfTI.
Status no_header(VoxelStream& stream, const std::string& path) {
  OSTEON_RETURN_IF_ERROR(stream.restart());
  uint8_t first[540];
  size_t got = 0;
  OSTEON_RETURN_IF_ERROR(stream.read(first, sizeof first, &got));
  return error(ErrorCode::kInvalidData, path, "not a NIfTI-1 or NIfTI-2 file: no valid header",
               "sizeof_hdr, magic");
}

Result<VoxelType> voxel_type(int datatype, const std::string& source) {
  switch (datatype) {
    case DT_UINT8:
      return VoxelType::kUint8;
    case DT_INT8:
      return VoxelType::kInt8;
    case DT_UINT16:
      return VoxelType::kUint16;
    case DT_INT16:
      return VoxelType::kInt16;
    case DT_UINT32:
      return VoxelType::kUint32;
    case DT_INT32:
      return VoxelType::kInt32;
    case DT_UINT64:
      return VoxelType::kUint64;
    case DT_INT64:
      return VoxelType::kInt64;
    case DT_FLOAT32:
      return VoxelType::kFloat32;
    case DT_FLOAT64:
      return VoxelType::kFloat64;
    default:
      break;
  }
  return error(ErrorCode::kUnsupported, source,
               "datatype " + std::to_string(datatype) + " (" + nifti_datatype_string(datatype) +
                   ") is not an integer or float type osteon reads",
               "datatype");
}

bool one_file_nifti(int nifti_type) {
#if defined(NIFTI_FTYPE_NIFTI2_1)
  if (nifti_type == NIFTI_FTYPE_NIFTI2_1) return true;
#endif
  return nifti_type == NIFTI_FTYPE_NIFTI1_1;
}

std::string number(double v) {
  char text[64];
  std::snprintf(text, sizeof text, "%g", v);
  return text;
}

Status check_header(const RawHeader& h, const std::string& source) {
  if (h.dim[0] < 1 || h.dim[0] > 7) {
    return error(ErrorCode::kInvalidData, source,
                 "dim[0] is " + std::to_string(h.dim[0]) + ", not a dimension count of 1 to 7",
                 "dim[0]");
  }
  for (int i = 1; i <= h.dim[0]; ++i) {
    const std::string field = "dim[" + std::to_string(i) + "]";
    if (h.dim[i] < 1) {
      return error(ErrorCode::kInvalidData, source,
                   field + " is " + std::to_string(h.dim[i]) + ": no voxels", field);
    }
    if (i <= 3 && h.dim[i] > std::numeric_limits<uint32_t>::max()) {
      return error(ErrorCode::kUnsupported, source,
                   field + " is " + std::to_string(h.dim[i]) + ", over 2^32 - 1 voxels a side",
                   field);
    }
  }
  if (!std::isfinite(h.vox_offset)) {
    return error(ErrorCode::kInvalidData, source, "vox_offset is not a number", "vox_offset");
  }
  return {};
}

// pixdim[1..3], where the grid's placement uses them.
Status check_pixdim(const RawHeader& h, const std::string& source) {
  static const char* const kAxes[3] = {"i", "j", "k"};
  for (int i = 1; i <= 3; ++i) {
    if (!(h.pixdim[i] > 0) || !std::isfinite(h.pixdim[i])) {
      return error(ErrorCode::kInvalidData, source,
                   "voxel size " + number(h.pixdim[i]) + " along " + kAxes[i - 1] +
                       ": voxel sizes must be positive",
                   "pixdim[" + std::to_string(i) + "]");
    }
  }
  return {};
}

// The grid's placement in osteon's frame (mm, LPS), by the sform, the qform, or pixdim alone.
Status place_grid(const RawHeader& h, const nifti_image& nim, const std::string& source,
                  LabelVolume* volume) {
  double unit = 1;  // to millimetres
  switch (nim.xyz_units) {
    case NIFTI_UNITS_UNKNOWN:
    case NIFTI_UNITS_MM:
      break;
    case NIFTI_UNITS_METER:
      unit = 1000;
      break;
    case NIFTI_UNITS_MICRON:
      unit = 0.001;
      break;
    default:
      volume->notes.push_back("xyz_units " + std::to_string(nim.xyz_units) +
                              " is not a length unit: millimetres assumed");
      break;
  }
  double m[3][4] = {};  // RAS+, rows x, y, z
  std::string field;
  if (h.sform_code > 0) {
    field = "srow_x, srow_y, srow_z (sform)";
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) m[r][c] = h.srow[r][c];
    }
  } else if (h.qform_code > 0) {
    field = "quatern_b, quatern_c, quatern_d, qoffset (qform)";
    OSTEON_RETURN_IF_ERROR(check_pixdim(h, source));
    static const char* const kNames[6] = {"quatern_b", "quatern_c", "quatern_d",
                                          "qoffset_x", "qoffset_y", "qoffset_z"};
    for (int i = 0; i < 6; ++i) {
      if (!std::isfinite(h.quatern[i])) {
        return error(ErrorCode::kInvalidData, source,
                     std::string(kNames[i]) + " is not a finite number", kNames[i]);
      }
    }
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) m[r][c] = nim.qto_xyz.m[r][c];
    }
  } else {
    field = "pixdim";
    OSTEON_RETURN_IF_ERROR(check_pixdim(h, source));
    for (int i = 0; i < 3; ++i) m[i][i] = h.pixdim[i + 1];
    volume->notes.push_back(
        "no sform or qform: the grid is placed by pixdim alone (voxel sizes along RAS x, y, z from "
        "the origin)");
  }
  // RAS+ to LPS: x and y change sign.
  Mat4 world = kIdentityMatrix;
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 3; ++r) world[4 * c + r] = (r < 2 ? -1 : 1) * m[r][c] * unit;
  }
  OSTEON_RETURN_IF_ERROR(check_index_to_world(world, source, field));
  volume->index_to_world = world;
  return {};
}

}  // namespace

Status read_nifti(const std::string& path, const VolumeReadOptions& options, LabelVolume* volume) {
  VoxelStream stream;
  OSTEON_RETURN_IF_ERROR(stream.open(path, 0, DataEncoding::kDetect, path, "data"));

  VoxelLayout layout;
  std::vector<VolumeLabel> named;
  {
    std::lock_guard<std::mutex> lock(nifti_mutex());
    nifti_set_debug_level(0);

    // The header alone, as the file holds it.
    RawHeader h;
    // What libnifti would print about rather than return: an ASCII header (.nia), and with
    // niftiio a NIfTI-2 header. A corrupt gzip stream fails here, with zlib's reason.
    uint8_t first[12] = {};
    size_t got = 0;
    OSTEON_RETURN_IF_ERROR(stream.read(first, sizeof first, &got));
    OSTEON_RETURN_IF_ERROR(stream.restart());
    if (got == sizeof first && std::memcmp(first, "<nifti_image", 12) == 0) {
      return error(ErrorCode::kUnsupported, path, "an ASCII NIfTI header (.nia): osteon reads .nii",
                   "magic");
    }
#if !defined(OSTEON_NIFTI2)
    if (got >= 4 && nifti2_size(first)) {
      return error(ErrorCode::kUnsupported, path,
                   "a NIfTI-2 file: this build's libnifti (niftiio) reads NIfTI-1 only",
                   "sizeof_hdr");
    }
#endif
    if (!read_raw_header(path, &h)) return no_header(stream, path);
    if (!h.one_file) {
      return error(ErrorCode::kUnsupported, path,
                   "a two-file NIfTI header (.hdr and .img): osteon reads one-file .nii", "magic");
    }
    OSTEON_RETURN_IF_ERROR(check_header(h, path));
    OSTEON_ASSIGN_OR_RETURN(layout.type, voxel_type(h.datatype, path));

    // The bytes up to the voxels must be there before libnifti sizes extensions from them.
    const double vox_offset = std::max<double>(h.vox_offset, h.header_bytes);
    if (vox_offset > static_cast<double>(stream.max_bytes())) {
      return error(ErrorCode::kInvalidData, path,
                   "the voxels would begin at byte " + number(vox_offset) + ", past what the " +
                       std::to_string(stream.file_size()) + "-byte file holds",
                   "vox_offset");
    }
    const uint64_t offset = static_cast<uint64_t>(vox_offset);
    OSTEON_RETURN_IF_ERROR(stream.skip(offset, "vox_offset"));
    stream.mark_start();

    std::unique_ptr<nifti_image, FreeImage> nim(nifti_image_read(path.c_str(), 0));
    if (nim == nullptr) {
      return error(ErrorCode::kInvalidData, path, "libnifti cannot read the header",
                   "sizeof_hdr, magic");
    }
    if (!one_file_nifti(nim->nifti_type)) {
      return error(ErrorCode::kUnsupported, path, "not a one-file NIfTI-1 or NIfTI-2 (.nii) header",
                   "magic");
    }

    // The grid.
    for (int i = 0; i < 3; ++i) {
      layout.size[i] = i < h.dim[0] ? static_cast<uint32_t>(h.dim[i + 1]) : 1;
    }
    uint64_t volumes = 1;
    for (int i = 4; i <= h.dim[0]; ++i) {
      if (!checked_multiply(volumes, static_cast<uint64_t>(h.dim[i]), &volumes)) {
        volumes = std::numeric_limits<uint64_t>::max();
      }
    }
    if (volumes > 1) {
      volume->notes.push_back("4-D volume: the first of " + std::to_string(volumes) +
                              " volumes is read");
    }
    OSTEON_RETURN_IF_ERROR(place_grid(h, *nim, path, volume));

    // The voxels.
    layout.big_endian = nim->byteorder == kMsbFirst;
    if (std::isfinite(nim->scl_slope) && nim->scl_slope != 0) {
      layout.slope = nim->scl_slope;
      layout.intercept = std::isfinite(nim->scl_inter) ? nim->scl_inter : 0;
    }
    uint64_t bytes = uint64_t{layout.size[0]} * layout.size[1];
    if (!checked_multiply(bytes, layout.size[2], &bytes) ||
        !checked_multiply(bytes, volumes, &bytes) ||
        !checked_multiply(bytes, static_cast<uint64_t>(voxel_type_bytes(layout.type)), &bytes)) {
      bytes = std::numeric_limits<uint64_t>::max();
    }
    layout.declared_bytes = bytes;
    layout.stream_bytes =
        bytes <= std::numeric_limits<uint64_t>::max() - offset ? offset + bytes : 0;
    layout.size_field = "dim";

    // A Caret/Workbench label table in an extension of code 0 (TotalSegmentator) or 30 (Caret).
    for (int e = 0; e < nim->num_ext; ++e) {
      const nifti1_extension& ext = nim->ext_list[e];
      if ((ext.ecode != NIFTI_ECODE_IGNORE && ext.ecode != NIFTI_ECODE_CARET) ||
          ext.edata == nullptr || ext.esize <= 8) {
        continue;
      }
      std::string_view xml(ext.edata, static_cast<size_t>(ext.esize - 8));
      if (xml.find("<LabelTable") == std::string_view::npos) continue;
      OSTEON_ASSIGN_OR_RETURN(
          named, parse_caret_label_table(xml, path,
                                         "NIfTI extension " + std::to_string(e) + " (ecode " +
                                             std::to_string(ext.ecode) + ")"));
      break;
    }
  }
  return decode_voxels(stream, layout, named, options, path, volume);
}

}  // namespace osteon::detail
