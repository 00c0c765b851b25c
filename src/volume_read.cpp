// SPDX-License-Identifier: Apache-2.0
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cassert>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <string>
#include <unordered_map>
#include <vector>

#include <tbb/task_group.h>
#include <zlib.h>

#include "core/huge_pages.hpp"
#include "osteon/volume.hpp"
#include "volume_internal.hpp"

// Based on: the streaming design of ITK's ImageIO (read a region, not the whole image) applied to
// label maps, and RFC 1950-1952 (zlib, deflate, gzip) for the bounds: deflate decodes at most 1032
// bytes a compressed byte, and gzip's trailer holds the decoded size modulo 2^32.
//
// The readers of each format (volume_nifti.cpp, volume_nrrd.cpp) check the header and place the
// grid in the world; this file turns the file's values, a slab at a time, into the dense labels
// of a LabelVolume, decides whether the volume holds labels at all, and thresholds it when not.

namespace osteon {

namespace detail {

namespace {

constexpr uint64_t kSlabBytes = uint64_t{4} << 20;  // file bytes converted at a time
constexpr size_t kSkipChunk = size_t{64} << 10;
constexpr uint32_t kMaxUnnamedLabels = 4096;  // more distinct values, nothing named: intensity
constexpr uint32_t kMaxLabels = 65535;        // dense ids are 16 bits
constexpr uint32_t kUnassigned = std::numeric_limits<uint32_t>::max();

// zlib's message without the "<fd:N>: " that gzdopen's streams prefix it with.
std::string zlib_message(gzFile gz) {
  int code = Z_OK;
  const char* text = gzerror(gz, &code);
  std::string message = text != nullptr ? text : "";
  if (message.starts_with("<fd:")) {
    const size_t colon = message.find(": ");
    if (colon != std::string::npos) message.erase(0, colon + 2);
  }
  return message.empty() ? "zlib error " + std::to_string(code) : message;
}

// Why a volume is not a label volume.
enum class NotLabels { kNo, kNegative, kFraction, kTooLarge, kTooMany };

const char* not_labels_reason(NotLabels why) {
  switch (why) {
    case NotLabels::kNo:
      break;
    case NotLabels::kNegative:
      return "negative values";
    case NotLabels::kFraction:
      return "values that are not integers";
    case NotLabels::kTooLarge:
      return "values over 4294967295";
    case NotLabels::kTooMany:
      return "more than 4096 distinct values and no label table";
  }
  return "";
}

template <class T>
T load_value(const uint8_t* p, bool swap) {
  if constexpr (sizeof(T) == 1) {
    (void)swap;
    return static_cast<T>(*p);
  } else {
    using Bits = std::conditional_t<sizeof(T) == 2, uint16_t,
                                    std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>>;
    Bits bits;
    std::memcpy(&bits, p, sizeof bits);
    if (swap) {
      if constexpr (sizeof(T) == 2) bits = __builtin_bswap16(bits);
      if constexpr (sizeof(T) == 4) bits = __builtin_bswap32(bits);
      if constexpr (sizeof(T) == 8) bits = __builtin_bswap64(bits);
    }
    return std::bit_cast<T>(bits);
  }
}

// The label a file value stands for, or why it stands for none.
template <class T>
NotLabels to_label(T x, uint32_t* label) {
  if constexpr (std::is_floating_point_v<T>) {
    if (!(x >= 0)) return std::isnan(x) ? NotLabels::kFraction : NotLabels::kNegative;
    if (x > 4294967295.0) return std::isinf(x) ? NotLabels::kFraction : NotLabels::kTooLarge;
    if (x != std::floor(x)) return NotLabels::kFraction;
    *label = static_cast<uint32_t>(x);
  } else {
    if constexpr (std::is_signed_v<T>) {
      if (x < 0) return NotLabels::kNegative;
    }
    if constexpr (sizeof(T) == 8) {
      if (static_cast<uint64_t>(x) > 4294967295u) return NotLabels::kTooLarge;
    }
    *label = static_cast<uint32_t>(x);
  }
  return NotLabels::kNo;
}

// Calls f(T{}) with T the C++ type of `type`.
template <class F>
Status visit_type(VoxelType type, F&& f) {
  switch (type) {
    case VoxelType::kUint8:
      return f(uint8_t{});
    case VoxelType::kInt8:
      return f(int8_t{});
    case VoxelType::kUint16:
      return f(uint16_t{});
    case VoxelType::kInt16:
      return f(int16_t{});
    case VoxelType::kUint32:
      return f(uint32_t{});
    case VoxelType::kInt32:
      return f(int32_t{});
    case VoxelType::kUint64:
      return f(uint64_t{});
    case VoxelType::kInt64:
      return f(int64_t{});
    case VoxelType::kFloat32:
      return f(float{});
    case VoxelType::kFloat64:
      return f(double{});
  }
  return {};
}

bool is_integer_type(VoxelType type) {
  return type != VoxelType::kFloat32 && type != VoxelType::kFloat64;
}

std::string format_value(double v, VoxelType type) {
  char text[64];
  if (is_integer_type(type) && std::fabs(v) < 9.007199254740992e15) {
    std::snprintf(text, sizeof text, "%.0f", v);
  } else {
    std::snprintf(text, sizeof text, "%g", v);
  }
  return text;
}

std::string format_number(double v) {
  char text[64];
  std::snprintf(text, sizeof text, "%g", v);
  return text;
}

// The conversion of one volume: the label pass, and when that finds an intensity volume, either
// the range pass (for the error message) or the threshold pass. Each pass reads the stream from
// the first voxel, one slab at a time.
class Decoder {
 public:
  Decoder(VoxelStream& stream, const VoxelLayout& layout, const std::vector<VolumeLabel>& named,
          const VolumeReadOptions& options, const std::string& source, LabelVolume* volume)
      : stream_(stream),
        layout_(layout),
        named_(named),
        options_(options),
        source_(source),
        volume_(volume) {}

  Status run() {
    OSTEON_RETURN_IF_ERROR(check_sizes());
    const uint64_t slice = uint64_t{layout_.size[0]} * layout_.size[1];
    const uint64_t slice_bytes = slice * stride_;
    slab_voxels_ = slice_bytes <= kSlabBytes
                       ? slice * std::max<uint64_t>(1, kSlabBytes / slice_bytes)
                       : std::max<uint64_t>(1, kSlabBytes / stride_);
    slab_voxels_ = std::min(slab_voxels_, voxel_count_);
    slab_.resize(static_cast<size_t>(slab_voxels_ * stride_));
    // A raw file was checked against its size, and a gzip stream whose trailer matches the
    // declared size almost surely holds it: reserve the labels at once. Otherwise they grow as
    // slabs arrive, so a short stream fails before the whole volume is allocated.
    const std::optional<uint32_t> isize = stream_.gzip_size_mod32();
    reserve_all_ =
        !stream_.gzip() || (isize && layout_.stream_bytes != 0 &&
                            *isize == static_cast<uint32_t>(layout_.stream_bytes & 0xffffffffu));

    OSTEON_RETURN_IF_ERROR(label_pass());
    if (not_labels_ == NotLabels::kNo) {
      finish_labels();
      return {};
    }
    // Not labels: the labels read so far go, and the stream starts again.
    std::vector<uint8_t>().swap(volume_->voxels);
    if (options_.threshold) return threshold_pass();
    return range_error();
  }

 private:
  Status check_sizes() {
    uint64_t count = 1;
    for (uint32_t extent : layout_.size) {
      assert(extent > 0);
      if (!checked_multiply(count, extent, &count)) count = std::numeric_limits<uint64_t>::max();
    }
    voxel_count_ = count;
    const std::string declared = std::to_string(layout_.size[0]) + " x " +
                                 std::to_string(layout_.size[1]) + " x " +
                                 std::to_string(layout_.size[2]) + " voxels";
    if (voxel_count_ > options_.max_voxel_bytes) {
      return error(ErrorCode::kInvalidData, source_,
                   declared + " need " + std::to_string(voxel_count_) +
                       " bytes of labels, over the limit of " +
                       std::to_string(options_.max_voxel_bytes) + " (max_voxel_bytes)",
                   layout_.size_field);
    }
    stride_ = uint64_t{layout_.components} * voxel_type_bytes(layout_.type);
    uint64_t first_volume = 0;
    if (!checked_multiply(voxel_count_, stride_, &first_volume)) {
      first_volume = std::numeric_limits<uint64_t>::max();
    }
    const uint64_t declared_bytes = std::max(layout_.declared_bytes, first_volume);
    const uint64_t room = stream_.max_bytes();
    if (declared_bytes > room) {
      std::string holds = stream_.gzip()
                              ? "a gzip stream of " + std::to_string(stream_.file_size()) +
                                    " bytes decodes to at most " + std::to_string(room)
                              : "the file holds " + std::to_string(room);
      return error(ErrorCode::kInvalidData, source_,
                   declared + " of " + voxel_type_name(layout_.type) + " need " +
                       std::to_string(declared_bytes) + " bytes of data; " + holds +
                       ": the file is truncated or its dimensions are wrong",
                   layout_.size_field);
    }
    swap_ = layout_.big_endian != (std::endian::native == std::endian::big);
    return {};
  }

  // Reads the stream slab by slab from the first voxel, calling slab(bytes, first, count) until
  // the volume is read or `stop_` is set. The next slab is read (and inflated) as a task beside
  // the call on the current one, into a second buffer: on a gzip volume the inflate and the
  // conversion overlap instead of taking turns.
  template <class F>
  Status each_slab(F&& slab) {
    stop_ = false;
    ahead_.resize(slab_.size());
    auto read_from = [&](uint64_t done, std::vector<uint8_t>& into) -> Status {
      const uint64_t count = std::min(slab_voxels_, voxel_count_ - done);
      const size_t want = static_cast<size_t>(count * stride_);
      size_t got = 0;
      OSTEON_RETURN_IF_ERROR(stream_.read(into.data(), want, &got));
      if (got < want) {
        return error(ErrorCode::kInvalidData, source_,
                     "the voxels end after " + std::to_string(done * stride_ + got) + " of " +
                         std::to_string(voxel_count_ * stride_) +
                         " bytes: the file is truncated or its dimensions are wrong",
                     layout_.size_field);
      }
      return {};
    };
    Status read = read_from(0, slab_);
    for (uint64_t done = 0; done < voxel_count_ && !stop_;) {
      OSTEON_RETURN_IF_ERROR(read);
      const uint64_t count = std::min(slab_voxels_, voxel_count_ - done);
      const uint64_t next = done + count;
      tbb::task_group reading;
      if (next < voxel_count_) reading.run([&] { read = read_from(next, ahead_); });
      const Status converted = slab(slab_.data(), done, count);
      reading.wait();
      OSTEON_RETURN_IF_ERROR(converted);
      slab_.swap(ahead_);
      done = next;
    }
    return {};
  }

  // ---- the label pass ----------------------------------------------------------------------

  Status label_pass() {
    volume_->bytes_per_voxel = 1;
    volume_->values.assign(1, 0);
    counts_.assign(1, 0);
    const size_t direct =
        layout_.type == VoxelType::kUint8 || layout_.type == VoxelType::kInt8 ? 256 : 65536;
    ids_.assign(direct, kUnassigned);
    ids_[0] = 0;
    if (reserve_all_) {
      volume_->voxels.reserve(static_cast<size_t>(voxel_count_));
      detail::advise_huge_pages(volume_->voxels.data(), volume_->voxels.capacity());
    }
    return visit_type(layout_.type, [&](auto tag) {
      using T = decltype(tag);
      return each_slab([&](const uint8_t* bytes, uint64_t first, uint64_t count) {
        return layout_.layer_labels.empty() ? label_slab<T>(bytes, first, count)
                                            : layer_slab<T>(bytes, first, count);
      });
    });
  }

  template <class T>
  Status label_slab(const uint8_t* bytes, uint64_t first, uint64_t count) {
    OSTEON_RETURN_IF_ERROR(grow(first + count));
    if constexpr (sizeof(T) == 1) {
      if (stride_ == 1) return byte_label_slab<T>(bytes, first, count);
    }
    for (uint64_t v = 0; v < count; ++v) {
      uint32_t label = 0;
      NotLabels why = to_label(load_value<T>(bytes + v * stride_, swap_), &label);
      if (why != NotLabels::kNo) return not_labels(why);
      uint32_t id = 0;
      OSTEON_RETURN_IF_ERROR(id_of(label, &id));
      if (stop_) return {};
      store(first + v, id);
    }
    return {};
  }

  // One byte a voxel (most label volumes): each byte's id comes from a table, and only a value
  // not seen before goes through to_label() and id_of(), so ids are given in the order the values
  // first appear, as the general loop gives them. 256 values need at most 256 ids: one byte out.
  // Counted in four histograms, so that a run of equal bytes does not wait on its own increments.
  template <class T>
  Status byte_label_slab(const uint8_t* bytes, uint64_t first, uint64_t count) {
    assert(volume_->bytes_per_voxel == 1 && ids_.size() >= 256);
    uint8_t* const out = volume_->voxels.data() + first;
    uint64_t histogram[4][256] = {};
    for (uint64_t v = 0; v < count; ++v) {
      const uint8_t x = bytes[v];
      uint32_t id = ids_[x];
      if (id == kUnassigned) [[unlikely]] {
        uint32_t label = 0;
        const NotLabels why = to_label(static_cast<T>(x), &label);
        if (why != NotLabels::kNo) return not_labels(why);
        OSTEON_RETURN_IF_ERROR(id_of(label, &id));
        if (stop_) return {};
      }
      out[v] = static_cast<uint8_t>(id);
      ++histogram[v & 3][x];
    }
    for (uint32_t x = 0; x < 256; ++x) {
      const uint64_t n = histogram[0][x] + histogram[1][x] + histogram[2][x] + histogram[3][x];
      if (n != 0) counts_[ids_[x]] += n;
    }
    return {};
  }

  // A Slicer segmentation of several layers: each voxel takes the segment of its first layer
  // that holds one.
  template <class T>
  Status layer_slab(const uint8_t* bytes, uint64_t first, uint64_t count) {
    OSTEON_RETURN_IF_ERROR(grow(first + count));
    const size_t type_bytes = sizeof(T);
    for (uint64_t v = 0; v < count; ++v) {
      uint32_t out = 0;
      int segments = 0;
      for (uint32_t layer = 0; layer < layout_.components; ++layer) {
        T x = load_value<T>(bytes + v * stride_ + layer * type_bytes, swap_);
        if (x == T{0}) continue;
        uint32_t value = 0;
        const std::vector<uint32_t>& names = layout_.layer_labels[layer];
        uint32_t label =
            to_label(x, &value) == NotLabels::kNo && value < names.size() ? names[value] : 0;
        if (label == 0) {
          return error(ErrorCode::kInvalidData, source_,
                       "layer " + std::to_string(layer) + " holds the value " +
                           format_value(static_cast<double>(x), layout_.type) + " at " +
                           voxel_name(first + v) + ", which no segment's LabelValue names",
                       "SegmentN_LabelValue");
        }
        if (segments++ == 0) out = label;
      }
      if (segments > 1) ++overlaps_;
      uint32_t id = 0;
      OSTEON_RETURN_IF_ERROR(id_of(out, &id));
      store(first + v, id);
    }
    return {};
  }

  Status not_labels(NotLabels why) {
    if (!layout_.layer_labels.empty()) {
      return error(ErrorCode::kInvalidData, source_,
                   std::string("a segmentation's layers hold ") + not_labels_reason(why), "type");
    }
    not_labels_ = why;
    stop_ = true;
    return {};
  }

  std::string voxel_name(uint64_t index) const {
    const uint64_t nx = layout_.size[0], ny = layout_.size[1];
    return "voxel (" + std::to_string(index % nx) + ", " + std::to_string(index / nx % ny) + ", " +
           std::to_string(index / (nx * ny)) + ")";
  }

  // The dense id of a label value, assigning the next one to a new value.
  Status id_of(uint32_t value, uint32_t* id) {
    if (value == last_value_) {
      *id = last_id_;
      return {};
    }
    uint32_t found = kUnassigned;
    if (value < ids_.size()) {
      found = ids_[value];
    } else if (auto it = large_ids_.find(value); it != large_ids_.end()) {
      found = it->second;
    }
    if (found == kUnassigned) {
      const size_t labels = volume_->values.size() - 1;
      if (named_.empty() && labels >= kMaxUnnamedLabels && layout_.layer_labels.empty()) {
        not_labels_ = NotLabels::kTooMany;
        stop_ = true;
        return {};
      }
      if (labels >= kMaxLabels) {
        return error(ErrorCode::kUnsupported, source_,
                     "more than " + std::to_string(kMaxLabels) + " distinct labels", "voxels");
      }
      found = static_cast<uint32_t>(volume_->values.size());
      volume_->values.push_back(value);
      counts_.push_back(0);
      if (value < ids_.size()) {
        ids_[value] = found;
      } else {
        large_ids_.emplace(value, found);
      }
      if (found == 256) OSTEON_RETURN_IF_ERROR(widen());
    }
    last_value_ = value;
    last_id_ = found;
    *id = found;
    return {};
  }

  void store(uint64_t index, uint32_t id) {
    ++counts_[id];
    std::vector<uint8_t>& voxels = volume_->voxels;
    if (volume_->bytes_per_voxel == 1) {
      voxels[static_cast<size_t>(index)] = static_cast<uint8_t>(id);
    } else {
      voxels[static_cast<size_t>(2 * index)] = static_cast<uint8_t>(id);
      voxels[static_cast<size_t>(2 * index + 1)] = static_cast<uint8_t>(id >> 8);
    }
  }

  // Makes room for `voxels` voxels: at once when reserved, else doubling up to the volume.
  Status grow(uint64_t voxels) {
    std::vector<uint8_t>& out = volume_->voxels;
    const uint64_t bytes = voxels * volume_->bytes_per_voxel;
    if (bytes > out.capacity()) {
      const uint64_t all = voxel_count_ * volume_->bytes_per_voxel;
      out.reserve(
          static_cast<size_t>(std::min(all, std::max(bytes, 2 * uint64_t{out.capacity()}))));
      detail::advise_huge_pages(out.data(), out.capacity());
    }
    out.resize(static_cast<size_t>(bytes));
    return {};
  }

  // The 256th label: two bytes a voxel from now on.
  Status widen() {
    if (2 * voxel_count_ > options_.max_voxel_bytes) {
      return error(ErrorCode::kInvalidData, source_,
                   "over 255 labels need " + std::to_string(2 * voxel_count_) +
                       " bytes of labels, over the limit of " +
                       std::to_string(options_.max_voxel_bytes) + " (max_voxel_bytes)",
                   "voxels");
    }
    const std::vector<uint8_t>& narrow = volume_->voxels;
    std::vector<uint8_t> wide;
    wide.reserve(static_cast<size_t>(reserve_all_ ? 2 * voxel_count_ : 2 * narrow.capacity()));
    wide.resize(2 * narrow.size());
    for (size_t i = 0; i < narrow.size(); ++i) wide[2 * i] = narrow[i];
    volume_->voxels.swap(wide);
    volume_->bytes_per_voxel = 2;
    return {};
  }

  void finish_labels() {
    std::map<uint32_t, VolumeLabel> table;
    for (const VolumeLabel& label : named_) {
      if (label.value == 0) continue;
      VolumeLabel& entry = table[label.value];
      entry = label;
      entry.voxels = 0;
    }
    for (size_t id = 1; id < volume_->values.size(); ++id) {
      VolumeLabel& entry = table[volume_->values[id]];
      entry.value = volume_->values[id];
      entry.voxels = counts_[id];
    }
    volume_->table.clear();
    for (auto& [value, label] : table) volume_->table.push_back(std::move(label));
    if (overlaps_ > 0) {
      volume_->notes.push_back(std::to_string(overlaps_) +
                               " voxels belong to segments of two or more layers: each takes the "
                               "segment of its first layer");
    }
    if (options_.threshold) {
      volume_->notes.push_back("a label volume: the threshold " +
                               format_number(*options_.threshold) + " is not applied");
    }
  }

  // ---- an intensity volume -----------------------------------------------------------------

  std::string scaling_text() {
    std::string scaled;
    if (layout_.slope != 1 || layout_.intercept != 0) {
      scaled = " * " + format_number(layout_.slope) + (layout_.intercept < 0 ? " - " : " + ") +
               format_number(std::fabs(layout_.intercept));
    }
    return scaled;
  }

  // Reads every value for the range the message gives, then refuses the volume.
  Status range_error() {
    OSTEON_RETURN_IF_ERROR(stream_.restart());
    double low = std::numeric_limits<double>::infinity();
    double high = -low;
    Status status = visit_type(layout_.type, [&](auto tag) {
      using T = decltype(tag);
      return each_slab([&](const uint8_t* bytes, uint64_t, uint64_t count) {
        for (uint64_t v = 0; v < count; ++v) {
          double x = static_cast<double>(load_value<T>(bytes + v * stride_, swap_));
          if (std::isnan(x)) continue;
          low = std::min(low, x);
          high = std::max(high, x);
        }
        return Status{};
      });
    });
    if (!status.ok()) return status;
    std::string range = std::isfinite(low) || std::isfinite(high)
                            ? " values from " + format_value(low, layout_.type) + " to " +
                                  format_value(high, layout_.type)
                            : " values, all NaN";
    return error(ErrorCode::kInvalidData, source_,
                 std::string("an intensity volume (") + voxel_type_name(layout_.type) + range +
                     ", " + not_labels_reason(not_labels_) +
                     "), not a label volume: give --threshold HU for a bone surface");
  }

  // Label 1, "bone", where value * slope + intercept >= threshold.
  Status threshold_pass() {
    OSTEON_RETURN_IF_ERROR(stream_.restart());
    const double threshold = *options_.threshold;
    volume_->bytes_per_voxel = 1;
    volume_->values.assign({0, 1});
    if (reserve_all_) volume_->voxels.reserve(static_cast<size_t>(voxel_count_));
    uint64_t bone = 0;
    const double slope = layout_.slope, intercept = layout_.intercept;
    Status status = visit_type(layout_.type, [&](auto tag) {
      using T = decltype(tag);
      return each_slab([&](const uint8_t* bytes, uint64_t first, uint64_t count) {
        OSTEON_RETURN_IF_ERROR(grow(first + count));
        uint8_t* out = volume_->voxels.data() + first;
        for (uint64_t v = 0; v < count; ++v) {
          double x = static_cast<double>(load_value<T>(bytes + v * stride_, swap_));
          uint8_t inside = x * slope + intercept >= threshold ? 1 : 0;
          out[v] = inside;
          bone += inside;
        }
        return Status{};
      });
    });
    if (!status.ok()) return status;
    VolumeLabel label;
    label.value = 1;
    label.name = "bone";
    label.voxels = bone;
    volume_->table.assign(1, label);
    volume_->notes.push_back(
        std::string("an intensity volume (") + voxel_type_name(layout_.type) + ", " +
        not_labels_reason(not_labels_) + "): label 1, \"bone\", where value" + scaling_text() +
        " >= " + format_number(threshold) + " (" + std::to_string(bone) + " voxels)");
    return {};
  }

  VoxelStream& stream_;
  const VoxelLayout& layout_;
  const std::vector<VolumeLabel>& named_;
  const VolumeReadOptions& options_;
  const std::string& source_;
  LabelVolume* volume_;

  uint64_t voxel_count_ = 0;
  uint64_t stride_ = 1;  // file bytes a voxel
  uint64_t slab_voxels_ = 1;
  std::vector<uint8_t> slab_;
  std::vector<uint8_t> ahead_;  // the next slab, read while slab_ is converted
  bool swap_ = false;
  bool reserve_all_ = false;
  bool stop_ = false;
  NotLabels not_labels_ = NotLabels::kNo;
  std::vector<uint32_t> ids_;  // label value -> dense id, for values below 256 or 65536
  std::unordered_map<uint32_t, uint32_t> large_ids_;
  std::vector<uint64_t> counts_;  // dense id -> voxels
  uint32_t last_value_ = 0;       // value 0 is id 0
  uint32_t last_id_ = 0;
  uint64_t overlaps_ = 0;
};

}  // namespace

int voxel_type_bytes(VoxelType type) {
  switch (type) {
    case VoxelType::kUint8:
    case VoxelType::kInt8:
      return 1;
    case VoxelType::kUint16:
    case VoxelType::kInt16:
      return 2;
    case VoxelType::kUint32:
    case VoxelType::kInt32:
    case VoxelType::kFloat32:
      return 4;
    case VoxelType::kUint64:
    case VoxelType::kInt64:
    case VoxelType::kFloat64:
      return 8;
  }
  return 1;
}

const char* voxel_type_name(VoxelType type) {
  switch (type) {
    case VoxelType::kUint8:
      return "uint8";
    case VoxelType::kInt8:
      return "int8";
    case VoxelType::kUint16:
      return "uint16";
    case VoxelType::kInt16:
      return "int16";
    case VoxelType::kUint32:
      return "uint32";
    case VoxelType::kInt32:
      return "int32";
    case VoxelType::kUint64:
      return "uint64";
    case VoxelType::kInt64:
      return "int64";
    case VoxelType::kFloat32:
      return "float32";
    case VoxelType::kFloat64:
      return "float64";
  }
  return "?";
}

std::string in_quotes(std::string_view text) {
  constexpr size_t kMax = 60;
  std::string out = "\"";
  for (size_t i = 0; i < text.size() && i < kMax; ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    out.push_back(c < 0x20 || c == 0x7f ? '?' : static_cast<char>(c));
  }
  if (text.size() > kMax) out += "...";
  return out + "\"";
}

bool checked_multiply(uint64_t a, uint64_t b, uint64_t* out) {
  return !__builtin_mul_overflow(a, b, out);
}

// ---- VoxelStream -----------------------------------------------------------------------------

VoxelStream::~VoxelStream() {
  close();
}

void VoxelStream::close() {
  if (gz_ != nullptr) {
    gzclose(gz_);  // closes fd_ too
  } else if (fd_ >= 0) {
    ::close(fd_);
  }
  gz_ = nullptr;
  fd_ = -1;
}

Status VoxelStream::open(const std::string& path, uint64_t file_offset, DataEncoding encoding,
                         const std::string& source, const std::string& field) {
  close();
  source_ = source;
  const std::string named = path == source ? std::string() : " " + path;
  fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) {
    return error(ErrorCode::kIoError, source, "cannot open" + named + ": " + std::strerror(errno));
  }
  struct stat st {};
  if (fstat(fd_, &st) != 0) {
    return error(ErrorCode::kIoError, source, "cannot stat" + named + ": " + std::strerror(errno));
  }
  if (S_ISDIR(st.st_mode)) {
    return error(ErrorCode::kIoError, source,
                 (named.empty() ? "" : named.substr(1) + " ") + "is a folder, not a file");
  }
  if (!S_ISREG(st.st_mode)) {
    return error(ErrorCode::kIoError, source,
                 (named.empty() ? "" : named.substr(1) + " ") + "is not a regular file");
  }
  file_size_ = static_cast<uint64_t>(st.st_size);
  if (file_offset > file_size_) {
    return error(ErrorCode::kInvalidData, source,
                 "the data would begin at byte " + std::to_string(file_offset) +
                     ", past the end of" + (named.empty() ? " the file" : named) + " (" +
                     std::to_string(file_size_) + " bytes)",
                 field);
  }
  file_offset_ = file_offset;
  position_ = start_ = 0;
  isize_.reset();
  bool is_gzip = false;
  if (encoding != DataEncoding::kRaw) {
    uint8_t magic[2] = {0, 0};
    is_gzip = pread(fd_, magic, 2, static_cast<off_t>(file_offset)) == 2 && magic[0] == 0x1f &&
              magic[1] == 0x8b;
    if (encoding == DataEncoding::kGzip && !is_gzip) {
      return error(ErrorCode::kInvalidData, source,
                   "the data" + named + " is not a gzip stream (no gzip magic at byte " +
                       std::to_string(file_offset) + ")",
                   field);
    }
  }
  if (lseek(fd_, static_cast<off_t>(file_offset), SEEK_SET) < 0) {
    return error(ErrorCode::kIoError, source, "cannot seek" + named + ": " + std::strerror(errno));
  }
  if (is_gzip) {
    uint8_t trailer[4];
    if (file_size_ - file_offset >= 18 &&
        pread(fd_, trailer, 4, static_cast<off_t>(file_size_ - 4)) == 4) {
      isize_ = uint32_t{trailer[0]} | uint32_t{trailer[1]} << 8 | uint32_t{trailer[2]} << 16 |
               uint32_t{trailer[3]} << 24;
    }
    gz_ = gzdopen(fd_, "rb");
    if (gz_ == nullptr) return error(ErrorCode::kIoError, source, "cannot start zlib" + named);
    gzbuffer(gz_, 256u << 10);
  }
  return {};
}

Status VoxelStream::read(uint8_t* out, size_t bytes, size_t* got) {
  *got = 0;
  while (*got < bytes) {
    const size_t want = std::min<size_t>(bytes - *got, size_t{1} << 30);
    if (gz_ != nullptr) {
      int n = gzread(gz_, out + *got, static_cast<unsigned>(want));
      int code = Z_OK;
      if (n <= 0) gzerror(gz_, &code);
      if (n < 0 || (n == 0 && code != Z_OK)) {
        const bool truncated = code == Z_BUF_ERROR;
        return error(ErrorCode::kInvalidData, source_,
                     std::string(truncated ? "truncated" : "corrupt") +
                         " gzip data (zlib: " + zlib_message(gz_) + ")",
                     "voxel data");
      }
      if (n == 0) break;
      *got += static_cast<size_t>(n);
    } else {
      ssize_t n = ::read(fd_, out + *got, want);
      if (n < 0) {
        if (errno == EINTR) continue;
        return error(ErrorCode::kIoError, source_,
                     std::string("cannot read: ") + std::strerror(errno));
      }
      if (n == 0) break;
      *got += static_cast<size_t>(n);
    }
  }
  position_ += *got;
  return {};
}

Status VoxelStream::skip(uint64_t bytes, const std::string& field) {
  std::vector<uint8_t> scratch(static_cast<size_t>(std::min<uint64_t>(bytes, kSkipChunk)));
  for (uint64_t left = bytes; left > 0;) {
    const size_t want = static_cast<size_t>(std::min<uint64_t>(left, scratch.size()));
    size_t got = 0;
    OSTEON_RETURN_IF_ERROR(read(scratch.data(), want, &got));
    if (got < want) {
      return error(ErrorCode::kInvalidData, source_,
                   "the data ends after " + std::to_string(position_) +
                       " bytes, before the voxels begin (" + std::to_string(bytes) +
                       " bytes to skip)",
                   field);
    }
    left -= got;
  }
  return {};
}

Status VoxelStream::restart() {
  if (gz_ != nullptr) {
    gzclearerr(gz_);  // a stream in error does not rewind; the error comes again on reading
    if (gzrewind(gz_) != 0) return error(ErrorCode::kIoError, source_, "cannot rewind zlib");
    position_ = 0;
    return skip(start_, "data");
  }
  if (lseek(fd_, static_cast<off_t>(file_offset_ + start_), SEEK_SET) < 0) {
    return error(ErrorCode::kIoError, source_, std::string("cannot seek: ") + std::strerror(errno));
  }
  position_ = start_;
  return {};
}

uint64_t VoxelStream::max_bytes() const {
  const uint64_t stored = file_size_ - file_offset_;
  if (gz_ == nullptr) return stored > start_ ? stored - start_ : 0;
  constexpr uint64_t kRatio = 1032;
  const uint64_t limit = stored > (std::numeric_limits<uint64_t>::max() - 1024) / kRatio
                             ? std::numeric_limits<uint64_t>::max()
                             : stored * kRatio + 1024;
  return limit > start_ ? limit - start_ : 0;
}

// ---- decoding --------------------------------------------------------------------------------

Status decode_voxels(VoxelStream& stream, const VoxelLayout& layout,
                     const std::vector<VolumeLabel>& named, const VolumeReadOptions& options,
                     const std::string& source, LabelVolume* volume) {
  volume->size = layout.size;
  Decoder decoder(stream, layout, named, options, source, volume);
  return decoder.run();
}

Status check_index_to_world(const Mat4& m, const std::string& source, const std::string& field) {
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 3; ++r) {
      if (!std::isfinite(m[4 * c + r])) {
        return error(ErrorCode::kInvalidData, source,
                     "the voxel-to-world transform holds a NaN or infinite number", field);
      }
    }
  }
  double lengths[3];
  static const char* const kAxes[3] = {"i", "j", "k"};
  for (int c = 0; c < 3; ++c) {
    lengths[c] =
        std::sqrt(m[4 * c] * m[4 * c] + m[4 * c + 1] * m[4 * c + 1] + m[4 * c + 2] * m[4 * c + 2]);
    if (!(lengths[c] > 0) || !std::isfinite(lengths[c])) {
      return error(ErrorCode::kInvalidData, source,
                   std::string("zero voxel size along ") + kAxes[c], field);
    }
  }
  const double det = determinant3(m);
  if (!(std::fabs(det) > 1e-9 * lengths[0] * lengths[1] * lengths[2])) {
    return error(ErrorCode::kInvalidData, source,
                 "the voxel-to-world transform is singular (its axes are coplanar)", field);
  }
  return {};
}

}  // namespace detail

bool is_volume_path(const std::string& path) {
  std::string lower = path;
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  auto ends_with = [&](const char* suffix) {
    const size_t n = std::strlen(suffix);
    return lower.size() > n && lower.compare(lower.size() - n, n, suffix) == 0;
  };
  return ends_with(".nii") || ends_with(".nii.gz") || ends_with(".nrrd") || ends_with(".nhdr");
}

Result<LabelVolume> read_volume(const std::string& path, const VolumeReadOptions& options) {
  LabelVolume volume;
  volume.source = path;
  std::string lower = path;
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  const bool nifti = lower.ends_with(".nii") || lower.ends_with(".nii.gz");
  const bool nrrd = lower.ends_with(".nrrd") || lower.ends_with(".nhdr");
  if (!is_volume_path(path) || (!nifti && !nrrd)) {
    return error(ErrorCode::kUnsupported, path,
                 "not a volume osteon reads (.nii, .nii.gz, .nrrd, .nhdr)");
  }
  Status status = nifti ? detail::read_nifti(path, options, &volume)
                        : detail::read_nrrd(path, options, &volume);
  if (!status.ok()) return status;
  return volume;
}

}  // namespace osteon
