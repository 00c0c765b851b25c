// SPDX-License-Identifier: Apache-2.0
// Legacy VTK reader: `DATASET POLYDATA` in ASCII or BINARY, file versions 1.0 to 5.1.
//
// Based on: "VTK File Formats" (the legacy format chapter of the VTK User's Guide, Kitware), and
// vtkDataReader / vtkPolyDataReader (VTK 9) for the details the text leaves open: binary data is
// big-endian and starts right after the end of the line that declares it (that line's newline is
// consumed, whatever follows the last keyword on it); keywords are case-insensitive; `vtkIdType`
// is written as a 32-bit int; files of version 5.x store cells as OFFSETS + CONNECTIVITY arrays.
//
// What this reader does with each section:
//   POINTS n type           the positions (any numeric type; double is rounded to float).
//   POLYGONS                fan-triangulated; cells with fewer than 3 corners give no triangle.
//   TRIANGLE_STRIPS         unrolled: triangle j of strip (v0..vk-1) is (vj, vj+1, vj+2) for even j
//                           and (vj+1, vj, vj+2) for odd j, so all keep the strip's orientation.
//                           Strip triangles that repeat an index are dropped: strips repeat
//                           indices on purpose to turn corners or join strips, and such a triangle
//                           has no area. (Polygon fans keep theirs; diagnose() reports them.)
//   VERTICES, LINES         read past and ignored (not surfaces).
//   FIELD, METADATA         read past.
//   POINT_DATA n            NORMALS become the per-vertex normals when n equals the point count.
//                           Every other attribute (SCALARS + LOOKUP_TABLE, COLOR_SCALARS, VECTORS,
//                           TEXTURE_COORDINATES, TENSORS, FIELD, GLOBAL_IDS, ...) is read past,
//                           as is CELL_DATA.
// The attribute sections are best effort: the geometry is complete before POINT_DATA starts, so
// anything there this reader cannot follow (an unknown keyword, a string array, truncation) ends
// the reading quietly and keeps the geometry; the normals are kept only when they were read whole
// and are all finite. Errors in the geometry sections are errors.
// Other datasets (UNSTRUCTURED_GRID, STRUCTURED_POINTS, ...) are kUnsupported.

#include <algorithm>
#include <cctype>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "core/byte_io.hpp"
#include "io_internal.hpp"

namespace osteon::detail {
namespace {

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (std::tolower(static_cast<unsigned char>(a[i])) !=
        std::tolower(static_cast<unsigned char>(b[i])))
      return false;
  }
  return true;
}

bool istarts_with(std::string_view text, std::string_view prefix) {
  return text.size() >= prefix.size() && iequals(text.substr(0, prefix.size()), prefix);
}

// ---- data types -----------------------------------------------------------------------------

enum class DataType { kBit, kU8, kI8, kU16, kI16, kU32, kI32, kU64, kI64, kF32, kF64 };

bool parse_data_type(std::string_view token, DataType* type) {
  struct Name {
    const char* name;
    DataType type;
  };
  // `long` is 8 bytes as VTK writes it on LP64 systems; `vtkIdType` is written as a 32-bit int.
  static const Name kNames[] = {
      {"bit", DataType::kBit},
      {"unsigned_char", DataType::kU8},
      {"char", DataType::kI8},
      {"signed_char", DataType::kI8},
      {"unsigned_short", DataType::kU16},
      {"short", DataType::kI16},
      {"unsigned_int", DataType::kU32},
      {"int", DataType::kI32},
      {"vtkidtype", DataType::kI32},
      {"unsigned_long", DataType::kU64},
      {"long", DataType::kI64},
      {"vtktypeuint64", DataType::kU64},
      {"vtktypeint64", DataType::kI64},
      {"vtktypeuint8", DataType::kU8},
      {"vtktypeint8", DataType::kI8},
      {"vtktypeuint16", DataType::kU16},
      {"vtktypeint16", DataType::kI16},
      {"vtktypeuint32", DataType::kU32},
      {"vtktypeint32", DataType::kI32},
      {"float", DataType::kF32},
      {"double", DataType::kF64},
  };
  for (const Name& n : kNames) {
    if (iequals(token, n.name)) {
      *type = n.type;
      return true;
    }
  }
  return false;
}

size_t type_bytes(DataType type) {
  switch (type) {
    case DataType::kBit:
      return 0;  // packed: see block_bytes
    case DataType::kU8:
    case DataType::kI8:
      return 1;
    case DataType::kU16:
    case DataType::kI16:
      return 2;
    case DataType::kU32:
    case DataType::kI32:
    case DataType::kF32:
      return 4;
    case DataType::kU64:
    case DataType::kI64:
    case DataType::kF64:
      return 8;
  }
  return 0;
}

bool is_float_type(DataType type) {
  return type == DataType::kF32 || type == DataType::kF64;
}

// ---- the cursor -----------------------------------------------------------------------------

// Keyword lines are text in both encodings; the data after them is text (ASCII) or big-endian
// binary (BINARY). Text goes through a TextReader, which is restarted after every binary block;
// positions in messages are lines for ASCII files and byte offsets for binary ones.
class Cursor {
 public:
  Cursor(const uint8_t* data, size_t size, const std::string& source)
      : data_(data), size_(size), source_(source), text_(data, size) {}

  void set_binary(bool binary) { binary_ = binary; }
  bool binary() const { return binary_; }
  const std::string& source() const { return source_; }

  std::string_view token() { return text_.next_token(); }
  std::string_view token_on_line() { return text_.next_token_on_line(); }
  std::string_view rest_of_line() { return text_.rest_of_line(); }
  size_t offset() const { return base_ + text_.offset(); }
  size_t remaining() const { return size_ - offset(); }
  std::string where() const { return binary_ ? at_byte(offset()) : text_.where(); }

  /// Moves to where a data block starts: in a binary file, just past the end of the line that
  /// declared it (as vtkDataReader does); in an ASCII file the values are plain tokens.
  void begin_data() {
    if (binary_) (void)text_.rest_of_line();
  }
  /// A binary block of `bytes` at the current offset, or nullptr when the file is shorter.
  const uint8_t* take_bytes(size_t bytes) {
    if (bytes > remaining()) return nullptr;
    const uint8_t* p = data_ + offset();
    restart_at(offset() + bytes);
    return p;
  }

  Status fail(const std::string& what) const {
    return error(ErrorCode::kInvalidData, source_, what, where());
  }
  Status fail_at(const std::string& what, const std::string& where_text) const {
    return error(ErrorCode::kInvalidData, source_, what, where_text);
  }

 private:
  void restart_at(size_t offset) {
    base_ = offset;
    text_ = TextReader(data_ + offset, size_ - offset);
  }

  const uint8_t* data_;
  size_t size_;
  const std::string& source_;
  TextReader text_;
  size_t base_ = 0;
  bool binary_ = false;
};

/// Parses a count token: a non-negative integer.
bool parse_count(std::string_view token, uint64_t* out) {
  int64_t value = 0;
  if (!parse_int(token, &value) || value < 0) return false;
  *out = static_cast<uint64_t>(value);
  return true;
}

/// Reads the next token as a count, or fails naming `what`.
Status read_count(Cursor& c, const char* what, uint64_t* out) {
  std::string_view token = c.token();
  if (!parse_count(token, out)) {
    return c.fail(std::string("expected ") + what + ", found '" + std::string(token) + "'");
  }
  return {};
}

Status read_data_type(Cursor& c, const char* keyword, DataType* type) {
  std::string_view token = c.token();
  if (parse_data_type(token, type)) return {};
  if (token.empty()) return c.fail(std::string(keyword) + ": the data type is missing");
  return error(ErrorCode::kUnsupported, c.source(),
               std::string(keyword) + ": data type '" + std::string(token) + "' is not supported",
               c.where());
}

// Reads `count` values of `type` (T = double or int64_t), or only skips them when `out` is null.
// The count is checked against the bytes that remain before anything is allocated. With
// `finite_group` > 0 a NaN or infinite value fails as vertex (index / finite_group).
template <class T>
Status read_values(Cursor& c, DataType type, uint64_t count, const std::string& what,
                   std::vector<T>* out, size_t finite_group = 0) {
  constexpr bool kWantInt = std::is_same_v<T, int64_t>;
  if (kWantInt && is_float_type(type)) return c.fail(what + " must have an integer type");
  if (c.binary()) {
    size_t item = type_bytes(type);
    uint64_t bytes = type == DataType::kBit ? count / 8 + (count % 8 != 0 ? 1 : 0) : 0;
    if (type != DataType::kBit) {
      if (count > c.remaining() / item) {
        return c.fail(what + ": " + std::to_string(count) + " values declared, room for " +
                      std::to_string(c.remaining() / item));
      }
      bytes = count * item;
    } else if (bytes > c.remaining()) {
      return c.fail(what + ": " + std::to_string(count) + " bits declared, room for " +
                    std::to_string(c.remaining() * 8));
    }
    size_t block_start = c.offset();
    const uint8_t* p = c.take_bytes(static_cast<size_t>(bytes));
    if (out == nullptr) return {};
    out->resize(static_cast<size_t>(count));
    T* dst = out->data();
    constexpr auto kBig = std::endian::big;
    for (size_t i = 0; i < count; ++i) {
      const uint8_t* q = p + i * item;
      switch (type) {
        case DataType::kBit:
          dst[i] = static_cast<T>((p[i / 8] >> (7 - i % 8)) & 1);
          break;
        case DataType::kU8:
          dst[i] = static_cast<T>(q[0]);
          break;
        case DataType::kI8:
          dst[i] = static_cast<T>(static_cast<int8_t>(q[0]));
          break;
        case DataType::kU16:
          dst[i] = static_cast<T>(ByteReader::load<uint16_t>(q, kBig));
          break;
        case DataType::kI16:
          dst[i] = static_cast<T>(ByteReader::load<int16_t>(q, kBig));
          break;
        case DataType::kU32:
          dst[i] = static_cast<T>(ByteReader::load<uint32_t>(q, kBig));
          break;
        case DataType::kI32:
          dst[i] = static_cast<T>(ByteReader::load<int32_t>(q, kBig));
          break;
        case DataType::kI64:
          dst[i] = static_cast<T>(ByteReader::load<int64_t>(q, kBig));
          break;
        case DataType::kU64: {
          uint64_t v = ByteReader::load<uint64_t>(q, kBig);
          if (kWantInt && v > uint64_t{std::numeric_limits<int64_t>::max()}) {
            return c.fail_at(what + ": value " + std::to_string(v) + " is too large",
                             at_byte(block_start + i * item));
          }
          dst[i] = static_cast<T>(v);
          break;
        }
        case DataType::kF32:
          dst[i] = static_cast<T>(ByteReader::load<float>(q, kBig));
          break;
        case DataType::kF64:
          dst[i] = static_cast<T>(ByteReader::load<double>(q, kBig));
          break;
      }
      if constexpr (!kWantInt) {
        if (finite_group > 0 && !std::isfinite(dst[i])) {
          return non_finite_error(c.source(), i / finite_group,
                                  at_byte(block_start + (i - i % finite_group) * item));
        }
      }
    }
    return {};
  }

  // ASCII: every value takes at least one character and one separator.
  if (count > c.remaining() / 2 + 1) {
    return c.fail(what + ": " + std::to_string(count) + " values declared, room for at most " +
                  std::to_string(c.remaining() / 2 + 1));
  }
  if (out != nullptr) out->resize(static_cast<size_t>(count));
  for (size_t i = 0; i < count; ++i) {
    std::string_view token = c.token();
    if (token.empty()) {
      return c.fail(what + ": the file ends after " + std::to_string(i) + " of " +
                    std::to_string(count) + " values");
    }
    if (out == nullptr) continue;
    if constexpr (kWantInt) {
      int64_t v = 0;
      if (!parse_int(token, &v)) {
        return c.fail(what + ": '" + std::string(token) + "' is not an integer");
      }
      (*out)[i] = v;
    } else {
      float v = 0;
      if (!parse_float(token, &v)) {
        return c.fail(what + ": '" + std::string(token) + "' is not a number");
      }
      if (finite_group > 0 && !std::isfinite(v)) {
        return non_finite_error(c.source(), i / finite_group, c.where());
      }
      (*out)[i] = v;
    }
  }
  return {};
}

/// Skips a METADATA block: text lines up to the first empty one (VTK 8.1+ writes them after
/// arrays, in binary files too).
void skip_metadata(Cursor& c) {
  (void)c.rest_of_line();
  while (c.remaining() > 0) {
    if (c.rest_of_line().find_first_not_of(" \t\r") == std::string_view::npos) break;
  }
}

/// Skips `FIELD name k` and its k arrays (`name components tuples type` + data; `NULL_ARRAY`
/// stands for an empty one).
Status skip_field(Cursor& c) {
  (void)c.token();  // the field's name
  uint64_t arrays = 0;
  OSTEON_RETURN_IF_ERROR(read_count(c, "the FIELD's array count", &arrays));
  for (uint64_t a = 0; a < arrays; ++a) {
    std::string_view name = c.token();
    if (name.empty()) return c.fail("FIELD: the file ends inside the field");
    if (iequals(name, "NULL_ARRAY")) continue;
    if (iequals(name, "METADATA")) {  // belongs to the previous array
      skip_metadata(c);
      --a;
      continue;
    }
    uint64_t components = 0, tuples = 0;
    DataType type{};
    OSTEON_RETURN_IF_ERROR(read_count(c, "the FIELD array's component count", &components));
    OSTEON_RETURN_IF_ERROR(read_count(c, "the FIELD array's tuple count", &tuples));
    OSTEON_RETURN_IF_ERROR(read_data_type(c, "FIELD", &type));
    if (components != 0 && tuples > std::numeric_limits<uint64_t>::max() / components) {
      return c.fail("FIELD: the array is too large");
    }
    c.begin_data();
    OSTEON_RETURN_IF_ERROR(
        read_values<double>(c, type, components * tuples, "FIELD array", nullptr));
  }
  return {};
}

// ---- cells ----------------------------------------------------------------------------------

// One POLYGONS or TRIANGLE_STRIPS section in the 5.x form: cell c has the corners
// connectivity[offsets[c] .. offsets[c+1]).
struct CellSection {
  bool strips = false;
  std::vector<int64_t> offsets;
  std::vector<int64_t> connectivity;
  std::string where;
};

/// Reads the cells of `keyword n size`. Legacy files (version < 5) store `k i0 .. ik-1` per cell
/// as 32-bit ints; 5.x files store `OFFSETS type` (n values) then `CONNECTIVITY type` (size
/// values). `out` null: read past them.
Status read_cells(Cursor& c, const std::string& keyword, int major_version, CellSection* out) {
  std::string where = c.where();
  uint64_t n = 0, size = 0;
  OSTEON_RETURN_IF_ERROR(read_count(c, (keyword + "'s cell count").c_str(), &n));
  OSTEON_RETURN_IF_ERROR(read_count(c, (keyword + "'s size").c_str(), &size));
  std::vector<int64_t> offsets, connectivity;

  if (major_version >= 5) {
    DataType type{};
    std::string_view token = c.token();
    if (!iequals(token, "OFFSETS")) {
      return c.fail(keyword + ": expected OFFSETS, found '" + std::string(token) + "'");
    }
    OSTEON_RETURN_IF_ERROR(read_data_type(c, "OFFSETS", &type));
    c.begin_data();
    OSTEON_RETURN_IF_ERROR(read_values(c, type, n, keyword + " OFFSETS", out ? &offsets : nullptr));
    token = c.token();
    if (iequals(token, "METADATA")) {
      skip_metadata(c);
      token = c.token();
    }
    if (!iequals(token, "CONNECTIVITY")) {
      return c.fail(keyword + ": expected CONNECTIVITY, found '" + std::string(token) + "'");
    }
    OSTEON_RETURN_IF_ERROR(read_data_type(c, "CONNECTIVITY", &type));
    c.begin_data();
    std::string conn_where = c.where();
    OSTEON_RETURN_IF_ERROR(
        read_values(c, type, size, keyword + " CONNECTIVITY", out ? &connectivity : nullptr));
    if (out == nullptr) return {};
    if (offsets.empty()) offsets.push_back(0);  // "POLYGONS 0 0": no cells
    if (offsets.front() != 0) {
      return c.fail_at(
          keyword + ": the first offset is " + std::to_string(offsets.front()) + ", not 0", where);
    }
    for (size_t i = 1; i < offsets.size(); ++i) {
      if (offsets[i] < offsets[i - 1]) {
        return c.fail_at(keyword + ": offset " + std::to_string(i) + " decreases", where);
      }
    }
    if (static_cast<uint64_t>(offsets.back()) != size) {
      return c.fail_at(keyword + ": the last offset is " + std::to_string(offsets.back()) +
                           ", but CONNECTIVITY has " + std::to_string(size) + " values",
                       conn_where);
    }
  } else {
    c.begin_data();
    if (n > size) {
      return c.fail(keyword + ": " + std::to_string(n) + " cells cannot fit in " +
                    std::to_string(size) + " values");
    }
    OSTEON_RETURN_IF_ERROR(
        read_values(c, DataType::kI32, size, keyword, out ? &connectivity : nullptr));
    if (out == nullptr) return {};
    // Compact `k i0 .. ik-1` runs in place into connectivity + offsets.
    offsets.reserve(static_cast<size_t>(n) + 1);
    offsets.push_back(0);
    size_t read = 0, write = 0;
    for (uint64_t cell = 0; cell < n; ++cell) {
      if (read >= connectivity.size()) {
        return c.fail_at(keyword + ": " + std::to_string(n) + " cells declared, but the " +
                             std::to_string(size) + " values end after " + std::to_string(cell),
                         where);
      }
      int64_t k = connectivity[read++];
      if (k < 0 || static_cast<uint64_t>(k) > connectivity.size() - read) {
        return c.fail_at(keyword + ": cell " + std::to_string(cell) + " claims " +
                             std::to_string(k) + " corners, more than the values left",
                         where);
      }
      for (int64_t j = 0; j < k; ++j) connectivity[write++] = connectivity[read++];
      offsets.push_back(static_cast<int64_t>(write));
    }
    if (read != connectivity.size()) {
      return c.fail_at(keyword + ": size is " + std::to_string(size) + ", but the " +
                           std::to_string(n) + " cells use " + std::to_string(read) + " values",
                       where);
    }
    connectivity.resize(write);
  }
  out->offsets = std::move(offsets);
  out->connectivity = std::move(connectivity);
  out->where = std::move(where);
  return {};
}

/// Appends the triangles of `section` to `mesh`, checking every corner against the point count.
Status triangulate(const CellSection& section, const std::string& source, Mesh* mesh) {
  const size_t points = mesh->positions.size();
  const char* keyword = section.strips ? "TRIANGLE_STRIPS" : "POLYGONS";
  std::vector<uint32_t> corners;
  for (size_t cell = 0; cell + 1 < section.offsets.size(); ++cell) {
    size_t begin = static_cast<size_t>(section.offsets[cell]);
    size_t end = static_cast<size_t>(section.offsets[cell + 1]);
    corners.clear();
    for (size_t i = begin; i < end; ++i) {
      int64_t v = section.connectivity[i];
      if (v < 0 || static_cast<uint64_t>(v) >= points) {
        return error(ErrorCode::kInvalidData, source,
                     std::string(keyword) + ": cell " + std::to_string(cell) + " uses point " +
                         std::to_string(v) + ", but there are " + std::to_string(points) +
                         " points",
                     section.where);
      }
      corners.push_back(static_cast<uint32_t>(v));
    }
    if (corners.size() < 3) continue;
    if (!section.strips) {
      add_polygon_fan(*mesh, corners.data(), corners.size());
      continue;
    }
    for (size_t j = 0; j + 2 < corners.size(); ++j) {
      uint32_t a = corners[j], b = corners[j + 1], c = corners[j + 2];
      if (a == b || b == c || a == c) continue;
      if (j % 2 == 1) std::swap(a, b);
      mesh->indices.insert(mesh->indices.end(), {a, b, c});
    }
  }
  return {};
}

// ---- attributes -----------------------------------------------------------------------------

// Reads POINT_DATA / CELL_DATA sections after the geometry. Returns quietly at the end of the
// file or at anything it cannot follow (see the file comment); `normals` is set only when a
// NORMALS array of POINT_DATA with one entry per point was read whole and is finite.
void read_attributes(Cursor& c, bool point_data, uint64_t count, size_t points,
                     std::vector<Vec3>* normals) {
  for (;;) {
    std::string_view keyword = c.token();
    if (keyword.empty()) return;
    std::string kw(keyword);
    uint64_t per_item = 0;  // values per point/cell for the simple "NAME name type" arrays
    if (iequals(kw, "POINT_DATA") || iequals(kw, "CELL_DATA")) {
      point_data = iequals(kw, "POINT_DATA");
      if (!read_count(c, "an attribute count", &count).ok()) return;
      continue;
    }
    if (iequals(kw, "METADATA")) {
      skip_metadata(c);
      continue;
    }
    if (iequals(kw, "FIELD")) {
      if (!skip_field(c).ok()) return;
      continue;
    }
    if (iequals(kw, "SCALARS")) {
      (void)c.token();  // name
      DataType type{};
      if (!read_data_type(c, "SCALARS", &type).ok()) return;
      uint64_t components = 1;
      std::string_view token = c.token_on_line();
      if (!token.empty() && (!parse_count(token, &components) || components > 4)) return;
      if (!iequals(c.token(), "LOOKUP_TABLE")) return;  // VTK requires it after SCALARS
      (void)c.token();                                  // the table's name
      c.begin_data();
      if (count > std::numeric_limits<uint64_t>::max() / 4) return;
      if (!read_values<double>(c, type, count * components, "SCALARS", nullptr).ok()) return;
      continue;
    }
    if (iequals(kw, "LOOKUP_TABLE") || iequals(kw, "COLOR_SCALARS")) {
      (void)c.token();  // name
      uint64_t n = 0;
      if (!read_count(c, "a size", &n).ok()) return;
      uint64_t items = iequals(kw, "LOOKUP_TABLE") ? 4 : count;  // RGBA entries / points
      if (items != 0 && n > std::numeric_limits<uint64_t>::max() / items) return;
      c.begin_data();
      DataType type = c.binary() ? DataType::kU8 : DataType::kF32;
      if (!read_values<double>(c, type, n * items, kw, nullptr).ok()) return;
      continue;
    }
    if (iequals(kw, "TEXTURE_COORDINATES")) {
      (void)c.token();  // name
      if (!read_count(c, "a dimension", &per_item).ok() || per_item > 3) return;
    } else if (iequals(kw, "VECTORS") || iequals(kw, "NORMALS")) {
      per_item = 3;
    } else if (iequals(kw, "TENSORS")) {
      per_item = 9;
    } else if (iequals(kw, "TENSORS6")) {
      per_item = 6;
    } else if (iequals(kw, "GLOBAL_IDS") || iequals(kw, "PEDIGREE_IDS") ||
               iequals(kw, "EDGE_FLAGS")) {
      per_item = 1;
    } else {
      return;  // unknown: stop here, keeping what was read
    }
    if (!iequals(kw, "TEXTURE_COORDINATES")) (void)c.token();  // name
    DataType type{};
    if (!read_data_type(c, kw.c_str(), &type).ok()) return;
    c.begin_data();
    if (count > std::numeric_limits<uint64_t>::max() / 16) return;
    bool take = iequals(kw, "NORMALS") && point_data && count == points;
    std::vector<double> values;
    if (!read_values<double>(c, type, count * per_item, kw, take ? &values : nullptr).ok()) return;
    if (!take) continue;
    bool finite = std::all_of(values.begin(), values.end(),
                              [](double v) { return std::isfinite(static_cast<float>(v)); });
    if (!finite) continue;
    normals->resize(points);
    for (size_t i = 0; i < points; ++i) {
      (*normals)[i] = {static_cast<float>(values[3 * i]), static_cast<float>(values[3 * i + 1]),
                       static_cast<float>(values[3 * i + 2])};
    }
  }
}

}  // namespace

Status parse_vtk(const uint8_t* data, size_t size, const std::string& source,
                 const ReadOptions& /*options*/, Scene* scene) {
  Cursor c(data, size, source);

  // Header: "# vtk DataFile Version x.y", a title line, ASCII | BINARY, DATASET type.
  std::string_view magic = c.rest_of_line();
  constexpr std::string_view kMagic = "# vtk DataFile Version";
  if (!istarts_with(magic, kMagic)) {
    return error(ErrorCode::kInvalidData, source,
                 "not a legacy VTK file: it must begin with '# vtk DataFile Version'", "line 1");
  }
  int major_version = 3;  // no readable version: the classic layout
  {
    std::string_view version = magic.substr(kMagic.size());
    while (!version.empty() && version.front() == ' ') version.remove_prefix(1);
    int64_t major = 0;
    size_t dot = version.find('.');
    if (parse_int(version.substr(0, dot), &major) && major >= 1 && major < 100) {
      major_version = static_cast<int>(major);
    }
  }
  (void)c.rest_of_line();  // the title
  std::string_view encoding = c.token();
  if (iequals(encoding, "BINARY")) {
    c.set_binary(true);
  } else if (!iequals(encoding, "ASCII")) {
    return c.fail("expected ASCII or BINARY, found '" + std::string(encoding) + "'");
  }
  std::string_view token = c.token();
  if (!iequals(token, "DATASET")) {
    if (iequals(token, "FIELD") || iequals(token, "POINT_DATA") || iequals(token, "CELL_DATA")) {
      return error(ErrorCode::kUnsupported, source,
                   "the file holds data arrays but no DATASET (only POLYDATA is read)", c.where());
    }
    return c.fail("expected DATASET, found '" + std::string(token) + "'");
  }
  token = c.token();
  if (!iequals(token, "POLYDATA")) {
    return error(
        ErrorCode::kUnsupported, source,
        "DATASET " + std::string(token) + " is not supported (only POLYDATA surfaces are read)",
        c.where());
  }

  Mesh mesh;
  bool have_points = false;
  std::vector<CellSection> sections;
  uint64_t attribute_count = 0;
  bool attributes = false, point_data = false;
  for (;;) {
    std::string_view keyword = c.token();
    if (keyword.empty()) break;
    std::string kw(keyword);
    if (iequals(kw, "POINTS")) {
      if (have_points) return c.fail("a second POINTS section");
      uint64_t n = 0;
      DataType type{};
      OSTEON_RETURN_IF_ERROR(read_count(c, "the number of POINTS", &n));
      OSTEON_RETURN_IF_ERROR(read_data_type(c, "POINTS", &type));
      c.begin_data();
      if (n > c.remaining() / 3) {
        return c.fail("POINTS: " + std::to_string(n) + " points declared, room for at most " +
                      std::to_string(c.remaining() / 3));
      }
      if (n > std::numeric_limits<uint32_t>::max()) {
        return error(ErrorCode::kUnsupported, source, "more than 2^32 points are not supported",
                     c.where());
      }
      std::vector<double> xyz;
      OSTEON_RETURN_IF_ERROR(read_values(c, type, 3 * n, "POINTS", &xyz, 3));
      mesh.positions.resize(static_cast<size_t>(n));
      for (size_t i = 0; i < n; ++i) {
        mesh.positions[i] = {static_cast<float>(xyz[3 * i]), static_cast<float>(xyz[3 * i + 1]),
                             static_cast<float>(xyz[3 * i + 2])};
        if (!is_finite(mesh.positions[i])) {  // a finite double beyond float's range
          return non_finite_error(source, i, c.where());
        }
      }
      have_points = true;
    } else if (iequals(kw, "POLYGONS") || iequals(kw, "TRIANGLE_STRIPS")) {
      CellSection section;
      section.strips = iequals(kw, "TRIANGLE_STRIPS");
      OSTEON_RETURN_IF_ERROR(
          read_cells(c, section.strips ? "TRIANGLE_STRIPS" : "POLYGONS", major_version, &section));
      sections.push_back(std::move(section));
    } else if (iequals(kw, "VERTICES") || iequals(kw, "LINES")) {
      OSTEON_RETURN_IF_ERROR(
          read_cells(c, iequals(kw, "LINES") ? "LINES" : "VERTICES", major_version, nullptr));
    } else if (iequals(kw, "FIELD")) {
      OSTEON_RETURN_IF_ERROR(skip_field(c));
    } else if (iequals(kw, "METADATA")) {
      skip_metadata(c);
    } else if (iequals(kw, "POINT_DATA") || iequals(kw, "CELL_DATA")) {
      point_data = iequals(kw, "POINT_DATA");
      attributes = read_count(c, "an attribute count", &attribute_count).ok();
      break;
    } else {
      return c.fail("unknown keyword '" + kw + "' in POLYDATA");
    }
  }
  if (!have_points) {
    return error(ErrorCode::kInvalidData, source, "the POLYDATA has no POINTS section", c.where());
  }

  for (const CellSection& section : sections) {
    OSTEON_RETURN_IF_ERROR(triangulate(section, source, &mesh));
  }
  mesh.stored_vertices = mesh.positions.size();
  if (attributes) {
    read_attributes(c, point_data, attribute_count, mesh.positions.size(), &mesh.normals);
  }
  scene->parts.push_back(std::move(mesh));
  return {};
}

}  // namespace osteon::detail
