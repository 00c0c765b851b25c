// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <bit>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "core/byte_io.hpp"
#include "io_internal.hpp"

// Based on: Greg Turk, "The PLY Polygon File Format" (1994), with the extensions readers agree on
// (sized type names int8..float64, "vertex_index" beside "vertex_indices", a "tristrips" element
// whose lists restart at -1). The fast binary path follows miniply (Vilya Harvey): recognise the
// common layout (float x, y, z vertices; uchar-counted int index lists) from the header and read
// it straight from the bytes, leaving the general, per-property path for everything else.
//
// What the reader takes from a PLY file, and its choices:
// - ascii, binary_little_endian and binary_big_endian 1.0; every scalar type; properties in any
//   order; every element and property it does not use is skipped, lists included;
// - vertex x, y, z (required, any scalar type, must be finite) and nx, ny, nz as normals when all
//   three are scalar properties (a NaN or infinite normal drops the mesh's normals: they are a
//   hint, the positions are the data);
// - "face" lists named vertex_indices or vertex_index, of any size, fan-triangulated in file
//   order; a face of 0, 1 or 2 corners gives no triangle and is skipped (files in the wild hold
//   them), though its indices must still be in range;
// - "tristrips" lists unrolled with alternating winding; -1 restarts a strip, and triangles that
//   repeat an index (the stitches between strips) are dropped;
// - before anything is allocated, the header's counts are checked against the bytes after it:
//   each binary item needs its scalars and list counts, each ascii value at least two bytes.
// The result is one part with an empty name; stored_vertices is the vertex element's count.

namespace osteon::detail {

namespace {

constexpr size_t kNone = static_cast<size_t>(-1);

enum class PlyType : uint8_t {
  kInt8,
  kUint8,
  kInt16,
  kUint16,
  kInt32,
  kUint32,
  kFloat32,
  kFloat64
};
enum class PlyEncoding { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

size_t type_size(PlyType type) {
  switch (type) {
    case PlyType::kInt8:
    case PlyType::kUint8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUint16:
      return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32:
      return 4;
    case PlyType::kFloat64:
      return 8;
  }
  return 0;
}

bool is_integer(PlyType type) {
  return type != PlyType::kFloat32 && type != PlyType::kFloat64;
}

bool parse_type(std::string_view name, PlyType* type) {
  struct Name {
    std::string_view name;
    PlyType type;
  };
  static constexpr Name kNames[] = {
      {"char", PlyType::kInt8},      {"int8", PlyType::kInt8},       {"uchar", PlyType::kUint8},
      {"uint8", PlyType::kUint8},    {"short", PlyType::kInt16},     {"int16", PlyType::kInt16},
      {"ushort", PlyType::kUint16},  {"uint16", PlyType::kUint16},   {"int", PlyType::kInt32},
      {"int32", PlyType::kInt32},    {"uint", PlyType::kUint32},     {"uint32", PlyType::kUint32},
      {"float", PlyType::kFloat32},  {"float32", PlyType::kFloat32}, {"double", PlyType::kFloat64},
      {"float64", PlyType::kFloat64}};
  for (const Name& n : kNames) {
    if (n.name == name) {
      *type = n.type;
      return true;
    }
  }
  return false;
}

/// True when an integer read from an ascii file fits the property's type.
bool fits_type(PlyType type, int64_t v) {
  switch (type) {
    case PlyType::kInt8:
      return v >= INT8_MIN && v <= INT8_MAX;
    case PlyType::kUint8:
      return v >= 0 && v <= UINT8_MAX;
    case PlyType::kInt16:
      return v >= INT16_MIN && v <= INT16_MAX;
    case PlyType::kUint16:
      return v >= 0 && v <= UINT16_MAX;
    case PlyType::kInt32:
      return v >= INT32_MIN && v <= INT32_MAX;
    case PlyType::kUint32:
      return v >= 0 && v <= UINT32_MAX;
    case PlyType::kFloat32:
    case PlyType::kFloat64:
      return true;
  }
  return false;
}

/// A token from the file for a message: at most 32 characters, non-printable bytes as '?'.
/// A value for a message: an integer when it is one.
std::string number_text(double v) {
  if (std::isfinite(v) && v == std::floor(v) && std::fabs(v) < 1e18) {
    return std::to_string(static_cast<int64_t>(v));
  }
  return std::to_string(v);
}

/// double to float without the undefined behaviour of converting an out-of-range value.
float to_float(double v) {
  if (v > FLT_MAX) return std::numeric_limits<float>::infinity();
  if (v < -FLT_MAX) return -std::numeric_limits<float>::infinity();
  return static_cast<float>(v);
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kFloat32;  ///< the item type, for a list
  bool is_list = false;
  PlyType count_type = PlyType::kUint8;
};

struct PlyElement {
  std::string name;
  uint64_t count = 0;
  std::vector<PlyProperty> properties;

  bool has_list() const {
    return std::any_of(properties.begin(), properties.end(),
                       [](const PlyProperty& p) { return p.is_list; });
  }
  /// Bytes of one binary item when every list is empty (exact when the element has no list).
  uint64_t min_binary_bytes() const {
    uint64_t bytes = 0;
    for (const PlyProperty& p : properties) bytes += type_size(p.is_list ? p.count_type : p.type);
    return bytes;
  }
  size_t find(std::string_view property) const {
    for (size_t i = 0; i < properties.size(); ++i) {
      if (properties[i].name == property) return i;
    }
    return kNone;
  }
};

struct PlyHeader {
  PlyEncoding encoding = PlyEncoding::kAscii;
  std::vector<PlyElement> elements;
};

Status parse_header(TextReader& text, const std::string& source, PlyHeader* header) {
  if (text.next_token_on_line() != "ply") {
    return error(ErrorCode::kInvalidData, source, "not a PLY file: it does not begin with 'ply'",
                 "line 1");
  }
  text.skip_line();
  bool have_format = false;
  for (;;) {
    if (text.at_end()) {
      return error(ErrorCode::kInvalidData, source, "the header has no end_header line",
                   text.where());
    }
    std::string where = text.where();
    std::string_view key = text.next_token_on_line();
    if (key == "end_header") {
      text.skip_line();
      break;
    }
    if (key.empty() || key == "comment" || key == "obj_info") {
      text.skip_line();
      continue;
    }
    if (key == "format") {
      std::string_view encoding = text.next_token_on_line();
      std::string_view version = text.next_token_on_line();
      if (encoding == "ascii") {
        header->encoding = PlyEncoding::kAscii;
      } else if (encoding == "binary_little_endian") {
        header->encoding = PlyEncoding::kBinaryLittleEndian;
      } else if (encoding == "binary_big_endian") {
        header->encoding = PlyEncoding::kBinaryBigEndian;
      } else {
        return error(ErrorCode::kInvalidData, source, "unknown PLY format " + quote_token(encoding),
                     where);
      }
      if (version.substr(0, 2) != "1." && version != "1") {
        return error(ErrorCode::kUnsupported, source, "PLY version " + quote_token(version), where);
      }
      have_format = true;
    } else if (key == "element") {
      PlyElement element;
      element.name = std::string(text.next_token_on_line());
      std::string_view count_token = text.next_token_on_line();
      int64_t count = 0;
      if (element.name.empty() || !parse_int(count_token, &count) || count < 0) {
        return error(ErrorCode::kInvalidData, source,
                     "bad element line (expected 'element NAME COUNT')", where);
      }
      element.count = static_cast<uint64_t>(count);
      for (const PlyElement& other : header->elements) {
        if (other.name == element.name) {
          return error(ErrorCode::kInvalidData, source,
                       "element " + quote_token(element.name) + " is declared twice", where);
        }
      }
      header->elements.push_back(std::move(element));
    } else if (key == "property") {
      if (header->elements.empty()) {
        return error(ErrorCode::kInvalidData, source, "property before any element", where);
      }
      PlyProperty property;
      std::string_view type = text.next_token_on_line();
      bool good = true;
      if (type == "list") {
        property.is_list = true;
        std::string_view count_type = text.next_token_on_line();
        good = parse_type(count_type, &property.count_type) && is_integer(property.count_type);
        type = text.next_token_on_line();
        if (!good) {
          return error(ErrorCode::kInvalidData, source,
                       "list count type " + quote_token(count_type) + " is not an integer type",
                       where);
        }
      }
      if (!parse_type(type, &property.type)) {
        return error(ErrorCode::kInvalidData, source, "unknown property type " + quote_token(type),
                     where);
      }
      property.name = std::string(text.next_token_on_line());
      if (property.name.empty()) {
        return error(ErrorCode::kInvalidData, source, "property without a name", where);
      }
      header->elements.back().properties.push_back(std::move(property));
    } else {
      return error(ErrorCode::kInvalidData, source, "unknown header line " + quote_token(key),
                   where);
    }
    text.skip_line();
  }
  if (!have_format) {
    return error(ErrorCode::kInvalidData, source, "the header has no format line", "line 2");
  }
  return {};
}

// ---- value sources: one for binary (byte order E), one for ascii ----------------------------
// Both read one scalar of a PLY type as a double (every PLY integer fits a double exactly), say
// whether `count` values can still follow, skip values, and say where they are for messages.

template <class T, std::endian E>
T load(const uint8_t* p) {
  return ByteReader::load<T>(p, E);
}

template <std::endian E>
class BinarySource {
 public:
  static constexpr bool kBinary = true;
  static constexpr std::endian kOrder = E;
  explicit BinarySource(ByteReader* reader) : reader_(reader) {}

  ByteReader& reader() { return *reader_; }
  size_t mark() const { return reader_->offset(); }
  std::string where(size_t mark) const { return at_byte(mark); }
  std::string problem() const { return "the file ends"; }

  bool read(PlyType type, double* out) {
    size_t n = type_size(type);
    if (reader_->remaining() < n) return false;
    const uint8_t* p = reader_->current();
    switch (type) {
      case PlyType::kInt8:
        *out = static_cast<int8_t>(*p);
        break;
      case PlyType::kUint8:
        *out = *p;
        break;
      case PlyType::kInt16:
        *out = load<int16_t, E>(p);
        break;
      case PlyType::kUint16:
        *out = load<uint16_t, E>(p);
        break;
      case PlyType::kInt32:
        *out = load<int32_t, E>(p);
        break;
      case PlyType::kUint32:
        *out = load<uint32_t, E>(p);
        break;
      case PlyType::kFloat32:
        *out = load<float, E>(p);
        break;
      case PlyType::kFloat64:
        *out = load<double, E>(p);
        break;
    }
    return reader_->skip(n);
  }
  bool can_hold(uint64_t count, PlyType type) const {
    return reader_->fits(count, type_size(type));
  }
  bool skip(PlyType type, uint64_t count) {
    return can_hold(count, type) && reader_->skip(count * type_size(type));
  }
  /// Skips `count` items of an element without lists in one step.
  bool skip_items(const PlyElement& element, uint64_t count) {
    uint64_t bytes = element.min_binary_bytes();
    return reader_->fits(count, bytes) && reader_->skip(count * bytes);
  }

 private:
  ByteReader* reader_;
};

class AsciiSource {
 public:
  static constexpr bool kBinary = false;
  explicit AsciiSource(TextReader* text) : text_(text), line_(text->line()) {}

  size_t mark() const { return 0; }
  /// The line of the last value read (the item's line when, as usual, an item is one line).
  std::string where(size_t) const { return "line " + std::to_string(line_); }
  const std::string& problem() const { return problem_; }

  bool read(PlyType type, double* out) {
    std::string_view token = text_->next_token();
    line_ = text_->line();
    if (token.empty()) {
      problem_ = "the file ends";
      return false;
    }
    if (is_integer(type)) {
      int64_t v = 0;
      if (!parse_int(token, &v)) {
        problem_ = quote_token(token) + " is not an integer";
        return false;
      }
      if (!fits_type(type, v)) {
        problem_ = quote_token(token) + " is out of range for its type";
        return false;
      }
      *out = static_cast<double>(v);
    } else {
      float v = 0;
      if (!parse_float(token, &v)) {
        problem_ = quote_token(token) + " is not a number";
        return false;
      }
      *out = v;
    }
    return true;
  }
  /// Each value needs at least two bytes (a digit and a separator; the last one no separator).
  bool can_hold(uint64_t count, PlyType) const { return count <= (text_->remaining() + 1) / 2; }
  bool skip(PlyType, uint64_t count) {
    if (!can_hold(count, PlyType::kUint8)) {
      problem_ = "the file ends";
      return false;
    }
    for (uint64_t i = 0; i < count; ++i) {
      if (text_->next_token().empty()) {
        problem_ = "the file ends";
        return false;
      }
      line_ = text_->line();
    }
    return true;
  }
  bool skip_items(const PlyElement& element, uint64_t count) {
    return skip(PlyType::kUint8, count * element.properties.size());
  }

 private:
  TextReader* text_;
  size_t line_;
  std::string problem_;
};

// ---- what the reader takes from the file ----------------------------------------------------

struct PlyPlan {
  size_t vertex_element = kNone;
  size_t face_element = kNone;
  size_t strip_element = kNone;
  std::vector<int> vertex_roles;  ///< per vertex property: 0..5 = x y z nx ny nz, -1 unused
  bool with_normals = false;
  size_t face_list = kNone;   ///< the face element's index-list property
  size_t strip_list = kNone;  ///< the tristrips element's index-list property
  uint32_t vertex_count = 0;
};

struct PlyCounts {
  uint64_t short_faces = 0;  ///< faces of 0, 1 or 2 corners, skipped
  bool normals_finite = true;
};

template <class Source>
Status item_error(const Source& src, const std::string& source, const PlyElement& element,
                  uint64_t item, const std::string& what, size_t mark) {
  return error(
      ErrorCode::kInvalidData, source,
      "element " + quote_token(element.name) + " item " + std::to_string(item) + ": " + what,
      src.where(mark));
}

/// Reads a list's count and checks that the file can still hold that many items.
template <class Source>
Status read_list_count(Source& src, const std::string& source, const PlyElement& element,
                       uint64_t item, const PlyProperty& property, size_t mark, uint64_t* count) {
  double n = 0;
  if (!src.read(property.count_type, &n)) {
    return item_error(src, source, element, item, src.problem(), mark);
  }
  if (n < 0) {
    return item_error(src, source, element, item, "list count " + number_text(n) + " is negative",
                      mark);
  }
  *count = static_cast<uint64_t>(n);
  if (!src.can_hold(*count, property.type)) {
    return item_error(src, source, element, item,
                      "a list of " + number_text(n) + " values runs past the end of the file",
                      mark);
  }
  return {};
}

template <class Source>
Status skip_property(Source& src, const std::string& source, const PlyElement& element,
                     uint64_t item, const PlyProperty& property, size_t mark) {
  uint64_t count = 1;
  if (property.is_list) {
    OSTEON_RETURN_IF_ERROR(read_list_count(src, source, element, item, property, mark, &count));
  }
  if (!src.skip(property.type, count)) {
    return item_error(src, source, element, item, src.problem(), mark);
  }
  return {};
}

template <class Source>
Status skip_element(Source& src, const std::string& source, const PlyElement& element) {
  if (element.properties.empty()) return {};
  if (!element.has_list()) {
    if (!src.skip_items(element, element.count)) {
      return error(ErrorCode::kInvalidData, source,
                   "element " + quote_token(element.name) + ": " + src.problem(),
                   src.where(src.mark()));
    }
    return {};
  }
  for (uint64_t i = 0; i < element.count; ++i) {
    size_t mark = src.mark();
    for (const PlyProperty& property : element.properties) {
      OSTEON_RETURN_IF_ERROR(skip_property(src, source, element, i, property, mark));
    }
  }
  return {};
}

template <class Source>
Status read_vertices_generic(Source& src, const std::string& source, const PlyElement& element,
                             const PlyPlan& plan, Mesh* mesh, PlyCounts* counts) {
  for (uint64_t i = 0; i < element.count; ++i) {
    size_t mark = src.mark();
    double v[6] = {0, 0, 0, 0, 0, 0};
    for (size_t p = 0; p < element.properties.size(); ++p) {
      const PlyProperty& property = element.properties[p];
      if (property.is_list) {
        OSTEON_RETURN_IF_ERROR(skip_property(src, source, element, i, property, mark));
        continue;
      }
      double value = 0;
      if (!src.read(property.type, &value)) {
        return item_error(src, source, element, i, src.problem(), mark);
      }
      if (plan.vertex_roles[p] >= 0) v[plan.vertex_roles[p]] = value;
    }
    Vec3 position{to_float(v[0]), to_float(v[1]), to_float(v[2])};
    if (!is_finite(position)) return non_finite_error(source, i, src.where(mark));
    mesh->positions.push_back(position);
    if (plan.with_normals) {
      Vec3 normal{to_float(v[3]), to_float(v[4]), to_float(v[5])};
      if (!is_finite(normal)) counts->normals_finite = false;
      mesh->normals.push_back(normal);
    }
  }
  return {};
}

/// Appends the triangles of one triangle strip (-1 entries restart it); drops the triangles that
/// repeat an index, which strips use to stitch runs together.
void add_strip(Mesh& mesh, const std::vector<int64_t>& strip) {
  size_t run = 0;
  int64_t a = -1, b = -1;
  for (int64_t c : strip) {
    if (c < 0) {
      run = 0;
      continue;
    }
    if (run >= 2 && a != b && b != c && a != c) {
      uint32_t t[3] = {static_cast<uint32_t>(a), static_cast<uint32_t>(b),
                       static_cast<uint32_t>(c)};
      if (run % 2 == 1) std::swap(t[0], t[1]);
      mesh.indices.insert(mesh.indices.end(), t, t + 3);
    }
    a = b;
    b = c;
    ++run;
  }
}

/// Faces (fan-triangulated) or, with `strips`, triangle strips, through the per-property path.
template <class Source>
Status read_faces_generic(Source& src, const std::string& source, const PlyElement& element,
                          size_t list, bool strips, const PlyPlan& plan, Mesh* mesh,
                          PlyCounts* counts) {
  std::vector<uint32_t> corners;
  std::vector<int64_t> strip;
  for (uint64_t i = 0; i < element.count; ++i) {
    size_t mark = src.mark();
    for (size_t p = 0; p < element.properties.size(); ++p) {
      const PlyProperty& property = element.properties[p];
      if (p != list) {
        OSTEON_RETURN_IF_ERROR(skip_property(src, source, element, i, property, mark));
        continue;
      }
      uint64_t n = 0;
      OSTEON_RETURN_IF_ERROR(read_list_count(src, source, element, i, property, mark, &n));
      corners.clear();
      strip.clear();
      for (uint64_t k = 0; k < n; ++k) {
        double value = 0;
        if (!src.read(property.type, &value)) {
          return item_error(src, source, element, i, src.problem(), mark);
        }
        if (strips && value == -1) {
          strip.push_back(-1);
          continue;
        }
        if (!(value >= 0 && value < plan.vertex_count && value == std::floor(value))) {
          return item_error(src, source, element, i,
                            "vertex index " + number_text(value) + " out of range (" +
                                std::to_string(plan.vertex_count) + " vertices)",
                            mark);
        }
        if (strips) {
          strip.push_back(static_cast<int64_t>(value));
        } else {
          corners.push_back(static_cast<uint32_t>(value));
        }
      }
    }
    if (strips) {
      add_strip(*mesh, strip);
    } else if (corners.size() >= 3) {
      add_polygon_fan(*mesh, corners.data(), corners.size());
    } else {
      ++counts->short_faces;
    }
  }
  return {};
}

// ---- fast binary paths ----------------------------------------------------------------------

/// Vertices whose properties are all scalars with float32 x, y, z (and float32 nx, ny, nz when
/// there are normals): read at fixed offsets in a fixed stride, or copied in one block.
bool vertex_fast_path_fits(const PlyElement& element, const PlyPlan& plan) {
  if (element.has_list()) return false;
  for (size_t p = 0; p < element.properties.size(); ++p) {
    if (plan.vertex_roles[p] >= 0 && element.properties[p].type != PlyType::kFloat32) return false;
  }
  return true;
}

template <std::endian E>
Status read_vertices_fast(ByteReader& reader, const std::string& source, const PlyElement& element,
                          const PlyPlan& plan, Mesh* mesh, PlyCounts* counts) {
  size_t stride = static_cast<size_t>(element.min_binary_bytes());
  size_t count = static_cast<size_t>(element.count);
  if (!reader.fits(count, stride)) {
    return error(ErrorCode::kInvalidData, source,
                 "element 'vertex': " + std::to_string(count) + " vertices of " +
                     std::to_string(stride) + " bytes run past the end of the file",
                 at_byte(reader.offset()));
  }
  size_t offset[6] = {0, 0, 0, 0, 0, 0};
  for (size_t p = 0, at = 0; p < element.properties.size(); ++p) {
    if (plan.vertex_roles[p] >= 0) offset[plan.vertex_roles[p]] = at;
    at += type_size(element.properties[p].type);
  }
  if (count == 0) return {};
  const uint8_t* base = reader.current();
  size_t first = mesh->positions.size();
  mesh->positions.resize(first + count);
  Vec3* out = mesh->positions.data() + first;
  static_assert(sizeof(Vec3) == 12);
  if (E == std::endian::native && stride == 12 && offset[0] == 0 && offset[1] == 4 &&
      offset[2] == 8) {
    std::memcpy(static_cast<void*>(out), base, count * 12);
  } else {
    for (size_t i = 0; i < count; ++i) {
      const uint8_t* p = base + i * stride;
      out[i] = {load<float, E>(p + offset[0]), load<float, E>(p + offset[1]),
                load<float, E>(p + offset[2])};
    }
  }
  for (size_t i = 0; i < count; ++i) {
    if (!is_finite(out[i])) {
      return non_finite_error(source, i, at_byte(reader.offset() + i * stride));
    }
  }
  if (plan.with_normals) {
    mesh->normals.resize(first + count);
    Vec3* normals = mesh->normals.data() + first;
    for (size_t i = 0; i < count; ++i) {
      const uint8_t* p = base + i * stride;
      normals[i] = {load<float, E>(p + offset[3]), load<float, E>(p + offset[4]),
                    load<float, E>(p + offset[5])};
      if (!is_finite(normals[i])) counts->normals_finite = false;
    }
  }
  (void)reader.skip(count * stride);
  return {};
}

/// Faces whose only property is a uchar-counted list of int32 or uint32 indices (what most
/// writers produce). Triangles are written straight into the reserved index array.
template <std::endian E, class Index>
Status read_faces_fast(ByteReader& reader, const std::string& source, const PlyElement& element,
                       const PlyPlan& plan, Mesh* mesh, PlyCounts* counts) {
  // A signed index is read as its bits: a negative one is then >= 2^31, out of range too.
  const uint64_t limit = std::is_signed_v<Index>
                             ? std::min<uint64_t>(plan.vertex_count, uint64_t{1} << 31)
                             : plan.vertex_count;
  const uint8_t* begin = reader.current();
  const uint8_t* p = begin;
  const uint8_t* end = begin + reader.remaining();
  std::vector<uint32_t>& out = mesh->indices;
  size_t cursor = out.size();
  out.resize(std::max(out.capacity(), cursor + 3));
  std::vector<uint32_t> corners;

  auto fail = [&](uint64_t face, const std::string& what, const uint8_t* at) {
    out.resize(cursor);
    return error(ErrorCode::kInvalidData, source,
                 "element 'face' item " + std::to_string(face) + ": " + what,
                 at_byte(reader.offset() + static_cast<size_t>(at - begin)));
  };
  auto out_of_range = [&](uint64_t face, uint32_t bits, const uint8_t* at) {
    int64_t value = std::is_signed_v<Index> ? int64_t{static_cast<int32_t>(bits)} : int64_t{bits};
    return fail(face,
                "vertex index " + std::to_string(value) + " out of range (" +
                    std::to_string(plan.vertex_count) + " vertices)",
                at);
  };

  for (uint64_t f = 0; f < element.count; ++f) {
    const uint8_t* face = p;
    if (p == end) return fail(f, "the file ends", face);
    size_t n = *p++;
    if (static_cast<size_t>(end - p) < n * 4) return fail(f, "the file ends", face);
    if (n == 3) {
      uint32_t a = load<uint32_t, E>(p), b = load<uint32_t, E>(p + 4), c = load<uint32_t, E>(p + 8);
      if (a >= limit) return out_of_range(f, a, face);
      if (b >= limit) return out_of_range(f, b, face);
      if (c >= limit) return out_of_range(f, c, face);
      if (cursor + 3 > out.size()) out.resize(2 * out.size());
      out[cursor] = a;
      out[cursor + 1] = b;
      out[cursor + 2] = c;
      cursor += 3;
      p += 12;
      continue;
    }
    corners.resize(n);
    for (size_t k = 0; k < n; ++k, p += 4) {
      corners[k] = load<uint32_t, E>(p);
      if (corners[k] >= limit) return out_of_range(f, corners[k], face);
    }
    if (n < 3) {
      ++counts->short_faces;
      continue;
    }
    size_t needed = cursor + 3 * (n - 2);
    if (needed > out.size()) out.resize(std::max(needed, 2 * out.size()));
    for (size_t k = 1; k + 1 < n; ++k, cursor += 3) {
      out[cursor] = corners[0];
      out[cursor + 1] = corners[k];
      out[cursor + 2] = corners[k + 1];
    }
  }
  out.resize(cursor);
  (void)reader.skip(static_cast<size_t>(p - begin));
  return {};
}

// ---- the body -------------------------------------------------------------------------------

template <class Source>
Status read_body(Source& src, const std::string& source, const PlyHeader& header,
                 const PlyPlan& plan, Mesh* mesh, PlyCounts* counts) {
  for (size_t e = 0; e < header.elements.size(); ++e) {
    const PlyElement& element = header.elements[e];
    if (e == plan.vertex_element) {
      if constexpr (Source::kBinary) {
        constexpr std::endian kOrder = Source::kOrder;
        if (vertex_fast_path_fits(element, plan)) {
          OSTEON_RETURN_IF_ERROR(
              read_vertices_fast<kOrder>(src.reader(), source, element, plan, mesh, counts));
          continue;
        }
      }
      OSTEON_RETURN_IF_ERROR(read_vertices_generic(src, source, element, plan, mesh, counts));
    } else if (e == plan.face_element) {
      if constexpr (Source::kBinary) {
        constexpr std::endian kOrder = Source::kOrder;
        const PlyProperty& list = element.properties[plan.face_list];
        if (element.properties.size() == 1 && list.count_type == PlyType::kUint8) {
          if (list.type == PlyType::kInt32) {
            OSTEON_RETURN_IF_ERROR((read_faces_fast<kOrder, int32_t>(src.reader(), source, element,
                                                                     plan, mesh, counts)));
            continue;
          }
          if (list.type == PlyType::kUint32) {
            OSTEON_RETURN_IF_ERROR((read_faces_fast<kOrder, uint32_t>(src.reader(), source, element,
                                                                      plan, mesh, counts)));
            continue;
          }
        }
      }
      OSTEON_RETURN_IF_ERROR(
          read_faces_generic(src, source, element, plan.face_list, false, plan, mesh, counts));
    } else if (e == plan.strip_element) {
      OSTEON_RETURN_IF_ERROR(
          read_faces_generic(src, source, element, plan.strip_list, true, plan, mesh, counts));
    } else {
      OSTEON_RETURN_IF_ERROR(skip_element(src, source, element));
    }
  }
  return {};
}

/// Finds the elements and properties the reader uses; checks the header's counts against the
/// bytes that follow it, before anything is allocated.
Status make_plan(const PlyHeader& header, const std::string& source, size_t data_offset,
                 size_t remaining, const std::string& header_end, PlyPlan* plan) {
  for (size_t e = 0; e < header.elements.size(); ++e) {
    const std::string& name = header.elements[e].name;
    if (name == "vertex") plan->vertex_element = e;
    if (name == "face") plan->face_element = e;
    if (name == "tristrips") plan->strip_element = e;
  }
  if (plan->vertex_element == kNone) {
    return error(ErrorCode::kInvalidData, source, "the header declares no vertex element",
                 header_end);
  }
  const PlyElement& vertex = header.elements[plan->vertex_element];
  static constexpr std::string_view kRoles[6] = {"x", "y", "z", "nx", "ny", "nz"};
  plan->vertex_roles.assign(vertex.properties.size(), -1);
  size_t found[6];
  for (int r = 0; r < 6; ++r) {
    found[r] = vertex.find(kRoles[r]);
    if (found[r] != kNone && vertex.properties[found[r]].is_list) found[r] = kNone;
    if (found[r] != kNone) plan->vertex_roles[found[r]] = r;
  }
  if (found[0] == kNone || found[1] == kNone || found[2] == kNone) {
    return error(ErrorCode::kInvalidData, source,
                 "the vertex element lacks a scalar x, y or z property", header_end);
  }
  plan->with_normals = found[3] != kNone && found[4] != kNone && found[5] != kNone;
  if (!plan->with_normals) {
    for (int r = 3; r < 6; ++r) {
      if (found[r] != kNone) plan->vertex_roles[found[r]] = -1;
    }
  }
  if (vertex.count > UINT32_MAX) {
    return error(ErrorCode::kUnsupported, source,
                 "element 'vertex' declares " + std::to_string(vertex.count) +
                     " vertices; at most 4294967295 can be indexed",
                 header_end);
  }
  plan->vertex_count = static_cast<uint32_t>(vertex.count);

  auto find_list = [&](size_t e, size_t* list, bool both_names) -> Status {
    if (e == kNone) return {};
    const PlyElement& element = header.elements[e];
    *list = element.find("vertex_indices");
    if (*list == kNone && both_names) *list = element.find("vertex_index");
    if (*list == kNone || !element.properties[*list].is_list) {
      return error(ErrorCode::kInvalidData, source,
                   "element " + quote_token(element.name) + " has no vertex_indices list",
                   header_end);
    }
    return {};
  };
  OSTEON_RETURN_IF_ERROR(find_list(plan->face_element, &plan->face_list, true));
  OSTEON_RETURN_IF_ERROR(find_list(plan->strip_element, &plan->strip_list, false));
  if (plan->face_element == kNone && plan->strip_element == kNone) {
    return error(ErrorCode::kInvalidData, source,
                 "no triangles: the header declares no face or tristrips element", header_end);
  }

  // Every item needs at least its scalars and list counts (binary) or two bytes per property
  // (ascii), so the declared counts cannot claim more than the bytes that follow can hold.
  bool ascii = header.encoding == PlyEncoding::kAscii;
  uint64_t budget = ascii ? uint64_t{remaining} + 1 : uint64_t{remaining};
  for (const PlyElement& element : header.elements) {
    uint64_t item_bytes =
        ascii ? 2 * uint64_t{element.properties.size()} : element.min_binary_bytes();
    if (item_bytes == 0) continue;
    if (element.count > budget / item_bytes) {
      return error(ErrorCode::kInvalidData, source,
                   "element " + quote_token(element.name) + " declares " +
                       std::to_string(element.count) + " items of at least " +
                       std::to_string(item_bytes) + " bytes, more than the " +
                       std::to_string(remaining) + " bytes after the header can hold",
                   ascii ? header_end : at_byte(data_offset));
    }
    budget -= element.count * item_bytes;
  }
  return {};
}

/// Reserves once, after make_plan checked the counts: positions, normals, and three indices per
/// face that the bytes after the header could hold as a triangle.
void reserve(const PlyHeader& header, const PlyPlan& plan, size_t remaining, Mesh* mesh) {
  mesh->positions.reserve(plan.vertex_count);
  if (plan.with_normals) mesh->normals.reserve(plan.vertex_count);
  if (plan.face_element == kNone) return;
  const PlyElement& face = header.elements[plan.face_element];
  uint64_t triangle_bytes =
      header.encoding == PlyEncoding::kAscii
          ? 2 * (uint64_t{face.properties.size()} + 3)
          : face.min_binary_bytes() + 3 * type_size(face.properties[plan.face_list].type);
  uint64_t triangles = std::min<uint64_t>(face.count, remaining / triangle_bytes);
  mesh->indices.reserve(static_cast<size_t>(3 * triangles));
}

}  // namespace

Status parse_ply(const uint8_t* data, size_t size, const std::string& source,
                 const ReadOptions& options, Scene* scene) {
  (void)options;
  TextReader text(data, size);
  PlyHeader header;
  OSTEON_RETURN_IF_ERROR(parse_header(text, source, &header));
  size_t data_offset = text.offset();
  size_t remaining = size - data_offset;
  PlyPlan plan;
  OSTEON_RETURN_IF_ERROR(make_plan(header, source, data_offset, remaining, text.where(), &plan));

  Mesh mesh;
  PlyCounts counts;
  reserve(header, plan, remaining, &mesh);
  if (header.encoding == PlyEncoding::kAscii) {
    AsciiSource src(&text);
    OSTEON_RETURN_IF_ERROR(read_body(src, source, header, plan, &mesh, &counts));
  } else {
    ByteReader reader(data, size);
    (void)reader.seek(data_offset);
    if (header.encoding == PlyEncoding::kBinaryLittleEndian) {
      BinarySource<std::endian::little> src(&reader);
      OSTEON_RETURN_IF_ERROR(read_body(src, source, header, plan, &mesh, &counts));
    } else {
      BinarySource<std::endian::big> src(&reader);
      OSTEON_RETURN_IF_ERROR(read_body(src, source, header, plan, &mesh, &counts));
    }
  }
  if (mesh.indices.empty()) {
    std::string what = "no triangles";
    if (counts.short_faces > 0) {
      what += ": all " + std::to_string(counts.short_faces) + " faces have fewer than 3 corners";
    }
    return error(ErrorCode::kInvalidData, source, what);
  }
  if (!counts.normals_finite) mesh.normals.clear();
  mesh.stored_vertices = plan.vertex_count;
  scene->parts.push_back(std::move(mesh));
  return {};
}

}  // namespace osteon::detail
