// SPDX-License-Identifier: Apache-2.0
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "volume_internal.hpp"

// Based on: the NRRD format, version 5 (Teem's "NRRD file format" page: a magic line, "field:
// description" lines and "key:=value" pairs up to a blank line, then the data, or a detached
// header .nhdr naming its data file), and 3D Slicer's segmentation files (.seg.nrrd), whose
// 4-D form has a leading "list" axis of layers.
//
// The header is read here, not by Teem's libteem: its nrrdLoad reads the whole array in one
// allocation of the size the header declares and opens whatever detached path the header names.
// This reader bounds the header (1 MiB), streams the voxels slab by slab through
// decode_voxels, and opens a detached data file only inside the header's own folder.

namespace osteon::detail {

namespace {

namespace fs = std::filesystem;

constexpr size_t kMaxHeaderBytes = size_t{1} << 20;

struct NrrdHeader {
  std::map<std::string, std::string> fields;  // canonical name ("space directions") -> value
  std::vector<std::pair<std::string, std::string>> key_values;
  uint64_t data_offset = 0;  // the byte after the blank line that ends the header
  bool ended = false;        // by a blank line (else by the end of the file)
};

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

// A field's canonical name: lower case, single spaces ("datafile" and "data file" alike).
std::string canonical_field(std::string_view name) {
  static const std::pair<const char*, const char*> kAliases[] = {
      {"datafile", "data file"},
      {"byteskip", "byte skip"},
      {"lineskip", "line skip"},
      {"spacedirections", "space directions"},
      {"spaceorigin", "space origin"},
      {"spaceunits", "space units"},
      {"spacedimension", "space dimension"},
      {"centerings", "centers"},
      {"blocksize", "block size"},
      {"oldmin", "old min"},
      {"oldmax", "old max"},
      {"axismins", "axis mins"},
      {"axismaxs", "axis maxs"},
      {"measurementframe", "measurement frame"},
      {"sampleunits", "sample units"}};
  std::string out;
  for (char c : lower(trim(name))) {
    if (is_space(c)) {
      if (!out.empty() && out.back() != ' ') out.push_back(' ');
    } else {
      out.push_back(c);
    }
  }
  std::string squeezed;
  for (char c : out) {
    if (c != ' ') squeezed.push_back(c);
  }
  for (const auto& [alias, full] : kAliases) {
    if (squeezed == alias) return full;
  }
  return out;
}

// "\n" and "\\" in a key/value pair's value.
std::string unescape(std::string_view s) {
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '\\' && i + 1 < s.size() && (s[i + 1] == 'n' || s[i + 1] == '\\')) {
      out.push_back(s[i + 1] == 'n' ? '\n' : '\\');
      ++i;
    } else {
      out.push_back(s[i]);
    }
  }
  return out;
}

Status read_header(const std::string& path, NrrdHeader* header) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "rb"),
                                                       &std::fclose);
  if (file == nullptr) {
    return error(ErrorCode::kIoError, path, std::string("cannot open: ") + std::strerror(errno));
  }
  struct stat st {};
  if (fstat(fileno(file.get()), &st) != 0 || !S_ISREG(st.st_mode)) {
    return error(ErrorCode::kIoError, path,
                 S_ISDIR(st.st_mode) ? "is a folder, not a file" : "is not a regular file");
  }
  const uint64_t size = static_cast<uint64_t>(st.st_size);
  std::string text(static_cast<size_t>(std::min<uint64_t>(size, kMaxHeaderBytes)), '\0');
  if (std::fread(text.data(), 1, text.size(), file.get()) != text.size()) {
    return error(ErrorCode::kIoError, path, "cannot read the header");
  }
  if (text.size() < 8 || !text.starts_with("NRRD000") || text[7] < '1' || text[7] > '9') {
    return error(ErrorCode::kInvalidData, path, "not an NRRD file: no NRRD000x magic", "line 1");
  }
  size_t pos = text.find('\n');
  if (pos == std::string::npos) pos = text.size();
  ++pos;
  for (int line = 2; pos < text.size(); ++line) {
    size_t end = text.find('\n', pos);
    if (end == std::string::npos) {
      if (text.size() < size) {
        return error(ErrorCode::kInvalidData, path,
                     "the header runs past 1 MiB without the blank line that ends it",
                     "line " + std::to_string(line));
      }
      end = text.size();
    }
    std::string_view content(text.data() + pos, end - pos);
    if (!content.empty() && content.back() == '\r') content.remove_suffix(1);
    pos = end + 1;
    if (content.empty()) {
      header->ended = true;
      header->data_offset = std::min<uint64_t>(pos, size);
      return {};
    }
    if (content.front() == '#') continue;
    const size_t colon = content.find(':');
    if (colon == std::string_view::npos || colon == 0) {
      return error(ErrorCode::kInvalidData, path,
                   "a header line that is neither \"field: value\" nor \"key:=value\"",
                   "line " + std::to_string(line));
    }
    if (colon + 1 < content.size() && content[colon + 1] == '=') {
      header->key_values.emplace_back(std::string(content.substr(0, colon)),
                                      unescape(content.substr(colon + 2)));
      continue;
    }
    std::string name = canonical_field(content.substr(0, colon));
    auto [it, inserted] =
        header->fields.emplace(name, std::string(trim(content.substr(colon + 1))));
    if (!inserted) {
      return error(ErrorCode::kInvalidData, path,
                   "the field " + in_quotes(name) + " is given twice",
                   "line " + std::to_string(line));
    }
    // "data file: LIST": the header ends, file names follow (refused as several files).
    if (name == "data file" && it->second.starts_with("LIST")) break;
  }
  header->data_offset = size;
  return {};
}

// Splits a field's value at whitespace outside parentheses and quotes.
std::vector<std::string> tokens(std::string_view s) {
  std::vector<std::string> out;
  size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && is_space(s[i])) ++i;
    if (i >= s.size()) break;
    std::string token;
    int depth = 0;
    bool quoted = false;
    while (i < s.size() && (depth > 0 || quoted || !is_space(s[i]))) {
      if (s[i] == '"') quoted = !quoted;
      if (!quoted && s[i] == '(') ++depth;
      if (!quoted && s[i] == ')' && depth > 0) --depth;
      token.push_back(s[i++]);
    }
    out.push_back(std::move(token));
  }
  return out;
}

bool parse_double(std::string_view text, double* out) {
  text = trim(text);
  if (text.empty() || text.size() > 64) return false;
  std::string copy(text);
  char* end = nullptr;
  *out = std::strtod(copy.c_str(), &end);
  return end == copy.c_str() + copy.size();
}

bool parse_int64(std::string_view text, int64_t* out) {
  text = trim(text);
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  if (text.empty()) return false;
  auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), *out);
  return ec == std::errc() && ptr == text.data() + text.size();
}

// "(x,y,z)": three numbers (NaN allowed: the caller checks).
bool parse_vector(std::string_view token, Vec3d* out) {
  token = trim(token);
  if (token.size() < 2 || token.front() != '(' || token.back() != ')') return false;
  token = token.substr(1, token.size() - 2);
  double v[3];
  for (int i = 0; i < 3; ++i) {
    const size_t comma = i < 2 ? token.find(',') : token.size();
    if (comma == std::string_view::npos || !parse_double(token.substr(0, comma), &v[i])) {
      return false;
    }
    token = i < 2 ? token.substr(comma + 1) : std::string_view();
  }
  *out = {v[0], v[1], v[2]};
  return true;
}

Result<VoxelType> parse_type(const std::string& value, const std::string& source) {
  static const std::pair<const char*, VoxelType> kTypes[] = {
      {"signed char", VoxelType::kInt8},
      {"int8", VoxelType::kInt8},
      {"int8_t", VoxelType::kInt8},
      {"uchar", VoxelType::kUint8},
      {"unsigned char", VoxelType::kUint8},
      {"uint8", VoxelType::kUint8},
      {"uint8_t", VoxelType::kUint8},
      {"short", VoxelType::kInt16},
      {"short int", VoxelType::kInt16},
      {"signed short", VoxelType::kInt16},
      {"signed short int", VoxelType::kInt16},
      {"int16", VoxelType::kInt16},
      {"int16_t", VoxelType::kInt16},
      {"ushort", VoxelType::kUint16},
      {"unsigned short", VoxelType::kUint16},
      {"unsigned short int", VoxelType::kUint16},
      {"uint16", VoxelType::kUint16},
      {"uint16_t", VoxelType::kUint16},
      {"int", VoxelType::kInt32},
      {"signed int", VoxelType::kInt32},
      {"int32", VoxelType::kInt32},
      {"int32_t", VoxelType::kInt32},
      {"uint", VoxelType::kUint32},
      {"unsigned int", VoxelType::kUint32},
      {"uint32", VoxelType::kUint32},
      {"uint32_t", VoxelType::kUint32},
      {"longlong", VoxelType::kInt64},
      {"long long", VoxelType::kInt64},
      {"long long int", VoxelType::kInt64},
      {"signed long long", VoxelType::kInt64},
      {"signed long long int", VoxelType::kInt64},
      {"int64", VoxelType::kInt64},
      {"int64_t", VoxelType::kInt64},
      {"ulonglong", VoxelType::kUint64},
      {"unsigned long long", VoxelType::kUint64},
      {"unsigned long long int", VoxelType::kUint64},
      {"uint64", VoxelType::kUint64},
      {"uint64_t", VoxelType::kUint64},
      {"float", VoxelType::kFloat32},
      {"double", VoxelType::kFloat64},
  };
  std::string name;
  for (const std::string& word : tokens(lower(value))) name += (name.empty() ? "" : " ") + word;
  for (const auto& [type_name, type] : kTypes) {
    if (name == type_name) return type;
  }
  if (name == "block") {
    return error(ErrorCode::kUnsupported, source, "type block holds no numbers", "type");
  }
  return error(ErrorCode::kInvalidData, source, "unknown type " + in_quotes(value), "type");
}

// Millimetres per unit of a "space units" entry.
bool unit_scale(std::string unit, double* scale) {
  if (unit.size() >= 2 && unit.front() == '"' && unit.back() == '"') {
    unit = unit.substr(1, unit.size() - 2);
  }
  unit = lower(trim(unit));
  if (unit.empty() || unit == "mm" || unit == "millimeter" || unit == "millimetre") {
    *scale = 1;
  } else if (unit == "m" || unit == "meter" || unit == "metre") {
    *scale = 1000;
  } else if (unit == "cm") {
    *scale = 10;
  } else if (unit == "um" || unit == "micron" || unit == "\xc2\xb5m") {
    *scale = 0.001;
  } else {
    return false;
  }
  return true;
}

// The byte after `lines` lines of the data file from `offset` ("line skip").
Result<uint64_t> skip_lines(const std::string& data_path, uint64_t offset, int64_t lines,
                            const std::string& source) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(data_path.c_str(), "rb"),
                                                       &std::fclose);
  if (file == nullptr) {
    return error(ErrorCode::kIoError, source,
                 "cannot open " + in_quotes(data_path) + ": " + std::strerror(errno));
  }
  if (fseeko(file.get(), static_cast<off_t>(offset), SEEK_SET) != 0) {
    return error(ErrorCode::kInvalidData, source, "cannot seek to the data", "line skip");
  }
  for (int64_t seen = 0; seen < lines;) {
    int c = std::fgetc(file.get());
    if (c == EOF) {
      return error(ErrorCode::kInvalidData, source,
                   "the data ends after " + std::to_string(seen) + " of " + std::to_string(lines) +
                       " lines to skip",
                   "line skip");
    }
    ++offset;
    if (c == '\n') ++seen;
  }
  return offset;
}

// A detached data file: relative, without "..", inside the header's folder once links resolve.
Result<std::string> detached_path(const std::string& header_path, const std::string& name) {
  const std::string field = "data file";
  if (name.empty()) return error(ErrorCode::kInvalidData, header_path, "an empty data file", field);
  const std::vector<std::string> words = tokens(name);
  if (words.size() != 1 || name == "LIST" || name.find('%') != std::string::npos) {
    return error(
        ErrorCode::kUnsupported, header_path,
        "data split over several files (" + in_quotes(name) + "): osteon reads one data file",
        field);
  }
  fs::path relative(name);
  if (relative.is_absolute() || name.front() == '/') {
    return error(ErrorCode::kInvalidData, header_path,
                 "the data file " + in_quotes(name) +
                     " is an absolute path: it must lie in the header's folder",
                 field);
  }
  for (const fs::path& part : relative) {
    if (part == "..") {
      return error(
          ErrorCode::kInvalidData, header_path,
          "the data file " + in_quotes(name) + " climbs out of the header's folder (\"..\")",
          field);
    }
  }
  fs::path folder = fs::path(header_path).parent_path();
  if (folder.empty()) folder = ".";
  std::error_code ec;
  const fs::path root = fs::canonical(folder, ec);
  if (ec) return error(ErrorCode::kIoError, header_path, "cannot resolve the header's folder");
  fs::path target = fs::weakly_canonical(folder / relative, ec);
  if (ec) target = folder / relative;
  const std::string root_text = root.string();
  const std::string target_text = target.string();
  const bool inside = target_text.size() > root_text.size() &&
                      target_text.compare(0, root_text.size(), root_text) == 0 &&
                      (target_text[root_text.size()] == '/' || root_text == "/");
  if (!inside) {
    return error(ErrorCode::kInvalidData, header_path,
                 "the data file " + in_quotes(name) + " resolves outside the header's folder",
                 field);
  }
  return (folder / relative).string();
}

// Where the grid's axes lie: which of the file's axes are spatial.
struct Axes {
  int extra = -1;  // the non-spatial axis of a 4-D file (0 or 3), or -1
  int spatial[3] = {0, 1, 2};
};

Result<Axes> find_axes(int dimension, const std::vector<std::string>& directions,
                       const std::vector<std::string>& kinds, const std::string& source) {
  Axes axes;
  std::vector<bool> spatial(dimension, true);
  bool known = false;
  if (!directions.empty()) {
    for (int a = 0; a < dimension; ++a) spatial[a] = lower(directions[a]) != "none";
    known = true;
  } else if (!kinds.empty()) {
    for (int a = 0; a < dimension; ++a) {
      const std::string kind = lower(kinds[a]);
      if (kind == "???" || kind == "none") continue;
      spatial[a] = kind == "domain" || kind == "space";
      known = known || !spatial[a];
    }
  }
  if (dimension == 4 && !known) spatial[3] = false;  // a time series, by convention
  std::vector<int> extra;
  int s = 0;
  for (int a = 0; a < dimension; ++a) {
    if (!spatial[a]) {
      extra.push_back(a);
    } else if (s < 3) {
      axes.spatial[s++] = a;
    } else {
      ++s;
    }
  }
  const std::string field = directions.empty() ? "kinds" : "space directions";
  if (s != 3 || (dimension == 4 && extra.size() != 1)) {
    return error(ErrorCode::kUnsupported, source,
                 std::to_string(s) + " spatial axes in a " + std::to_string(dimension) +
                     "-D volume: osteon reads three",
                 field);
  }
  if (dimension == 4) {
    axes.extra = extra[0];
    if (axes.extra != 0 && axes.extra != 3) {
      return error(ErrorCode::kUnsupported, source,
                   "the non-spatial axis is axis " + std::to_string(axes.extra) +
                       ": osteon reads it first or last",
                   field);
    }
  }
  return axes;
}

// The grid's placement in osteon's frame (mm, LPS) from space, space directions, space origin,
// space units and spacings.
Status place_grid(const NrrdHeader& header, int dimension, const Axes& axes,
                  const std::vector<std::string>& directions, const std::string& source,
                  LabelVolume* volume) {
  auto get = [&](const char* name) -> const std::string* {
    auto it = header.fields.find(name);
    return it == header.fields.end() ? nullptr : &it->second;
  };
  double flip[3] = {1, 1, 1};  // to LPS
  if (const std::string* space = get("space")) {
    const std::string name = lower(*space);
    if (name == "right-anterior-superior" || name == "ras") {
      flip[0] = flip[1] = -1;
    } else if (name == "left-anterior-superior" || name == "las") {
      flip[1] = -1;
    } else if (name == "left-posterior-superior" || name == "lps") {
    } else if (name == "scanner-xyz" || name == "3d-right-handed" || name == "3d-left-handed") {
      volume->notes.push_back("space " + in_quotes(*space) +
                              " is not a patient space: taken as LPS");
    } else {
      return error(ErrorCode::kUnsupported, source,
                   "space " + in_quotes(*space) + ": osteon reads RAS, LAS and LPS volumes",
                   "space");
    }
  } else if (const std::string* dims = get("space dimension")) {
    int64_t n = 0;
    if (!parse_int64(*dims, &n) || n != 3) {
      return error(ErrorCode::kUnsupported, source,
                   "space dimension " + in_quotes(*dims) + ": osteon reads 3-D spaces",
                   "space dimension");
    }
    volume->notes.push_back("no named space: the space directions are taken as LPS");
  }
  double units[3] = {1, 1, 1};
  if (const std::string* text = get("space units")) {
    std::vector<std::string> words = tokens(*text);
    if (words.size() != 3) {
      return error(ErrorCode::kInvalidData, source,
                   "space units gives " + std::to_string(words.size()) + " units, not 3",
                   "space units");
    }
    for (int r = 0; r < 3; ++r) {
      if (!unit_scale(words[r], &units[r])) {
        return error(ErrorCode::kUnsupported, source,
                     "space unit " + in_quotes(words[r]) + ": osteon reads mm, cm, m and um",
                     "space units");
      }
    }
  }
  Vec3d origin{0, 0, 0};
  if (const std::string* text = get("space origin")) {
    if (!parse_vector(*text, &origin)) {
      return error(ErrorCode::kInvalidData, source,
                   "space origin " + in_quotes(*text) + " is not a vector (x,y,z)", "space origin");
    }
  }
  Vec3d columns[3];
  std::string field;
  if (!directions.empty()) {
    field = "space directions";
    for (int s = 0; s < 3; ++s) {
      const std::string& token = directions[axes.spatial[s]];
      if (!parse_vector(token, &columns[s])) {
        return error(ErrorCode::kInvalidData, source,
                     "space direction " + in_quotes(token) + " of axis " +
                         std::to_string(axes.spatial[s]) + " is not a vector (x,y,z)",
                     field);
      }
    }
  } else {
    field = "spacings";
    double spacing[3] = {1, 1, 1};
    if (const std::string* text = get("spacings")) {
      std::vector<std::string> words = tokens(*text);
      if (static_cast<int>(words.size()) != dimension) {
        return error(ErrorCode::kInvalidData, source,
                     "spacings gives " + std::to_string(words.size()) + " values for " +
                         std::to_string(dimension) + " axes",
                     field);
      }
      for (int s = 0; s < 3; ++s) {
        const std::string& word = words[axes.spatial[s]];
        if (!parse_double(word, &spacing[s]) || !(spacing[s] > 0) || !std::isfinite(spacing[s])) {
          return error(ErrorCode::kInvalidData, source,
                       "spacing " + in_quotes(word) + " of axis " +
                           std::to_string(axes.spatial[s]) + ": voxel sizes must be positive",
                       field);
        }
      }
      volume->notes.push_back(
          "no space directions: the grid is placed by spacings alone, its axes along x, y, z");
    } else {
      volume->notes.push_back("no space directions or spacings: 1 mm voxels along x, y, z");
    }
    for (int s = 0; s < 3; ++s) {
      columns[s] = {0, 0, 0};
      (s == 0 ? columns[s].x : s == 1 ? columns[s].y : columns[s].z) = spacing[s];
      flip[s] = 1;
    }
  }
  Mat4 world = kIdentityMatrix;
  for (int c = 0; c < 4; ++c) {
    const Vec3d& v = c < 3 ? columns[c] : origin;
    const double xyz[3] = {v.x, v.y, v.z};
    for (int r = 0; r < 3; ++r) world[4 * c + r] = flip[r] * units[r] * xyz[r];
  }
  OSTEON_RETURN_IF_ERROR(check_index_to_world(world, source, field));
  volume->index_to_world = world;
  return {};
}

}  // namespace

Status read_nrrd(const std::string& path, const VolumeReadOptions& options, LabelVolume* volume) {
  NrrdHeader header;
  OSTEON_RETURN_IF_ERROR(read_header(path, &header));
  auto get = [&](const char* name) -> const std::string* {
    auto it = header.fields.find(name);
    return it == header.fields.end() ? nullptr : &it->second;
  };
  auto require = [&](const char* name, const std::string** out) -> Status {
    *out = get(name);
    if (*out == nullptr) {
      return error(ErrorCode::kInvalidData, path, std::string("no \"") + name + "\" field", name);
    }
    return {};
  };
  const std::string *type_text, *dimension_text, *sizes_text, *encoding_text;
  OSTEON_RETURN_IF_ERROR(require("type", &type_text));
  OSTEON_RETURN_IF_ERROR(require("dimension", &dimension_text));
  OSTEON_RETURN_IF_ERROR(require("sizes", &sizes_text));
  OSTEON_RETURN_IF_ERROR(require("encoding", &encoding_text));

  VoxelLayout layout;
  layout.size_field = "sizes";
  OSTEON_ASSIGN_OR_RETURN(layout.type, parse_type(*type_text, path));
  int64_t dimension = 0;
  if (!parse_int64(*dimension_text, &dimension) || dimension < 1 || dimension > 16) {
    return error(ErrorCode::kInvalidData, path, "dimension " + in_quotes(*dimension_text),
                 "dimension");
  }
  if (dimension != 3 && dimension != 4) {
    return error(ErrorCode::kUnsupported, path,
                 "dimension " + std::to_string(dimension) +
                     ": osteon reads 3-D volumes and the first volume of 4-D ones",
                 "dimension");
  }
  const int dim = static_cast<int>(dimension);
  std::vector<std::string> size_words = tokens(*sizes_text);
  if (static_cast<int>(size_words.size()) != dim) {
    return error(ErrorCode::kInvalidData, path,
                 "sizes gives " + std::to_string(size_words.size()) + " sizes for dimension " +
                     std::to_string(dim),
                 "sizes");
  }
  std::vector<uint64_t> sizes(dim);
  for (int a = 0; a < dim; ++a) {
    int64_t n = 0;
    if (!parse_int64(size_words[a], &n) || n < 1) {
      return error(ErrorCode::kInvalidData, path,
                   "size " + in_quotes(size_words[a]) + " of axis " + std::to_string(a) +
                       " is not a positive integer",
                   "sizes");
    }
    if (n > std::numeric_limits<uint32_t>::max()) {
      return error(ErrorCode::kUnsupported, path,
                   "size " + in_quotes(size_words[a]) + " of axis " + std::to_string(a) +
                       " is over 2^32 - 1",
                   "sizes");
    }
    sizes[a] = static_cast<uint64_t>(n);
  }

  const std::string encoding = lower(*encoding_text);
  bool gzip = false;
  if (encoding == "gzip" || encoding == "gz") {
    gzip = true;
  } else if (encoding != "raw") {
    const bool known = encoding == "bzip2" || encoding == "bz2" || encoding == "ascii" ||
                       encoding == "text" || encoding == "txt" || encoding == "hex" ||
                       encoding == "zstd";
    return error(known ? ErrorCode::kUnsupported : ErrorCode::kInvalidData, path,
                 "encoding " + in_quotes(*encoding_text) + ": osteon reads raw and gzip",
                 "encoding");
  }
  if (const std::string* endian = get("endian")) {
    const std::string name = lower(*endian);
    if (name != "little" && name != "big") {
      return error(ErrorCode::kInvalidData, path, "endian " + in_quotes(*endian), "endian");
    }
    layout.big_endian = name == "big";
  } else if (voxel_type_bytes(layout.type) > 1) {
    volume->notes.push_back("no endian field: little-endian assumed");
  }

  // Axes and placement.
  std::vector<std::string> directions, kinds;
  if (const std::string* text = get("space directions")) {
    directions = tokens(*text);
    if (static_cast<int>(directions.size()) != dim) {
      return error(ErrorCode::kInvalidData, path,
                   "space directions gives " + std::to_string(directions.size()) +
                       " directions for " + std::to_string(dim) + " axes",
                   "space directions");
    }
  }
  if (const std::string* text = get("kinds")) {
    kinds = tokens(*text);
    if (static_cast<int>(kinds.size()) != dim) {
      return error(ErrorCode::kInvalidData, path,
                   "kinds gives " + std::to_string(kinds.size()) + " kinds for " +
                       std::to_string(dim) + " axes",
                   "kinds");
    }
  }
  OSTEON_ASSIGN_OR_RETURN(Axes axes, find_axes(dim, directions, kinds, path));
  for (int s = 0; s < 3; ++s) layout.size[s] = static_cast<uint32_t>(sizes[axes.spatial[s]]);
  OSTEON_RETURN_IF_ERROR(place_grid(header, dim, axes, directions, path, volume));

  // Slicer's segments, and what the non-spatial axis holds.
  bool segmentation = false;
  for (const auto& kv : header.key_values) {
    if (kv.first.starts_with("Segment") && kv.first.size() > 7 && kv.first[7] >= '0' &&
        kv.first[7] <= '9') {
      segmentation = true;
      break;
    }
  }
  const uint32_t extra_size = axes.extra >= 0 ? static_cast<uint32_t>(sizes[axes.extra]) : 1;
  const std::string extra_kind =
      axes.extra >= 0 && !kinds.empty() ? lower(kinds[axes.extra]) : std::string();
  const bool layered =
      segmentation && axes.extra == 0 && (extra_kind.empty() || extra_kind == "list");
  constexpr uint32_t kMaxLayers = 4096;
  if (layered && extra_size > kMaxLayers) {
    return error(ErrorCode::kUnsupported, path,
                 "a segmentation of " + std::to_string(extra_size) +
                     " layers: osteon reads up to " + std::to_string(kMaxLayers),
                 "sizes");
  }
  std::vector<VolumeLabel> named;
  if (segmentation) {
    OSTEON_ASSIGN_OR_RETURN(
        std::vector<SlicerSegment> segments,
        parse_slicer_segments(header.key_values, layered ? extra_size : 1, path));
    bool unique = true;
    std::map<uint32_t, int> values;
    for (const SlicerSegment& segment : segments) {
      unique = unique && values.emplace(segment.label.value, segment.index).second;
    }
    if (layered) {
      if (!unique) {
        volume->notes.push_back(
            "the segmentation's layers reuse label values: its segments are numbered 1 to " +
            std::to_string(segments.size()) + " in their order");
      }
      layout.layer_labels.assign(extra_size, {});
      for (size_t i = 0; i < segments.size(); ++i) {
        const SlicerSegment& segment = segments[i];
        if (segment.label.value > 65535) {
          return error(ErrorCode::kUnsupported, path,
                       "label value " + std::to_string(segment.label.value) +
                           " over 65535 in a segmentation of several layers",
                       "Segment" + std::to_string(segment.index) + "_LabelValue");
        }
        std::vector<uint32_t>& map = layout.layer_labels[segment.layer];
        if (map.size() <= segment.label.value) map.resize(segment.label.value + 1, 0);
        VolumeLabel label = segment.label;
        if (!unique) label.value = static_cast<uint32_t>(i + 1);
        map[segment.label.value] = label.value;
        named.push_back(label);
      }
    } else {
      for (const SlicerSegment& segment : segments) named.push_back(segment.label);
    }
  }
  uint64_t volumes = 1;
  if (axes.extra == 0) {
    layout.components = extra_size;
    if (!layered && extra_size > 1) {
      volume->notes.push_back(
          "4-D volume: axis 0 holds " + std::to_string(extra_size) + " values a voxel" +
          (extra_kind.empty() ? "" : " (kind " + extra_kind + ")") + ": the first is read");
    }
  } else if (axes.extra == 3) {
    volumes = extra_size;
    if (volumes > 1) {
      volume->notes.push_back("4-D volume: the first of " + std::to_string(volumes) +
                              " volumes is read");
    }
  }
  uint64_t declared = static_cast<uint64_t>(voxel_type_bytes(layout.type));
  for (uint64_t n : sizes) {
    if (!checked_multiply(declared, n, &declared)) declared = std::numeric_limits<uint64_t>::max();
  }
  layout.declared_bytes = declared;

  // The data: attached after the blank line, or a detached file beside the header.
  std::string data_path = path;
  uint64_t offset = header.data_offset;
  if (const std::string* name = get("data file")) {
    OSTEON_ASSIGN_OR_RETURN(data_path, detached_path(path, *name));
    offset = 0;
  } else if (!header.ended) {
    return error(ErrorCode::kInvalidData, path,
                 lower(path).ends_with(".nhdr")
                     ? "a detached header (.nhdr) without a data file field"
                     : "the header does not end with the blank line before the data",
                 "data file");
  }
  if (const std::string* text = get("line skip")) {
    int64_t lines = 0;
    if (!parse_int64(*text, &lines) || lines < 0) {
      return error(ErrorCode::kInvalidData, path, "line skip " + in_quotes(*text), "line skip");
    }
    OSTEON_ASSIGN_OR_RETURN(offset, skip_lines(data_path, offset, lines, path));
  }
  int64_t byte_skip = 0;
  if (const std::string* text = get("byte skip")) {
    if (!parse_int64(*text, &byte_skip) || byte_skip < -1) {
      return error(ErrorCode::kInvalidData, path, "byte skip " + in_quotes(*text), "byte skip");
    }
  }
  if (byte_skip == -1) {
    if (gzip) {
      return error(ErrorCode::kInvalidData, path,
                   "byte skip -1 (the data at the file's end) is for raw data only", "byte skip");
    }
    std::error_code ec;
    const uint64_t size = fs::file_size(data_path, ec);
    if (ec) {
      return error(ErrorCode::kIoError, path,
                   "cannot open " + in_quotes(data_path) + ": " + ec.message());
    }
    if (declared > size - std::min(size, offset)) {
      return error(ErrorCode::kInvalidData, path,
                   "sizes of " + std::string(voxel_type_name(layout.type)) + " need " +
                       std::to_string(declared) + " bytes of data; the file holds " +
                       std::to_string(size - std::min(size, offset)),
                   "sizes");
    }
    offset = size - declared;
  } else if (!gzip) {
    offset += static_cast<uint64_t>(byte_skip);
  }
  VoxelStream stream;
  OSTEON_RETURN_IF_ERROR(stream.open(data_path, offset,
                                     gzip ? DataEncoding::kGzip : DataEncoding::kRaw, path,
                                     gzip ? "encoding" : "byte skip"));
  if (gzip && byte_skip > 0) {
    OSTEON_RETURN_IF_ERROR(stream.skip(static_cast<uint64_t>(byte_skip), "byte skip"));
  }
  stream.mark_start();
  if (gzip && declared <= std::numeric_limits<uint64_t>::max() - byte_skip) {
    layout.stream_bytes = declared + static_cast<uint64_t>(std::max<int64_t>(byte_skip, 0));
  }
  return decode_voxels(stream, layout, named, options, path, volume);
}

}  // namespace osteon::detail
