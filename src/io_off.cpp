// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/byte_io.hpp"
#include "io_internal.hpp"

// Based on: the OFF format as Geomview documents it ("OFF Files", Geomview manual, section 4.2.1):
// a "[ST][C][N][4][n]OFF" keyword, the counts "NVertices NFaces NEdges", one vertex per line
// (x y z, then a normal with N, a colour with C, texture coordinates with ST), then one face per
// line "n i0 i1 ... i(n-1)" optionally followed by a colour. The Princeton 3D Mesh Segmentation
// Benchmark (Chen, Golovinskiy, Funkhouser, SIGGRAPH 2009) stores its models as plain OFF and
// labels them one segment per face, in file order.
//
// What the reader takes, and its choices:
// - OFF, COFF, NOFF, CNOFF, STOFF, STCNOFF... and nOFF with dimension 3; the counts may also
//   follow the keyword on its line, and a file may lack the keyword and begin with the counts;
//   4OFF, nOFF of another dimension and BINARY OFF give kUnsupported;
// - '#' starts a comment anywhere; tokens may wrap across lines, but after the values it needs,
//   the reader drops the rest of a vertex's or face's line, so colours (3 or 4 values, integers
//   or floats) and texture coordinates are ignored whatever their count;
// - NOFF normals become the mesh's normals (a NaN or infinite one drops them all);
// - faces are fan-triangulated in file order: face f of n corners gives n - 2 consecutive
//   triangles, so a per-face label (a segmentation .seg file) maps to triangles by repeating it
//   n - 2 times; a face of 0, 1 or 2 corners gives no triangle (its indices must still be in
//   range). For all-triangle files, as in the benchmark, triangle t is face t;
// - before allocating, the counts are checked against the bytes left: every vertex needs three
//   values and every face one, each value at least two bytes ("0 ").
// The result is one part with an empty name; stored_vertices is the declared vertex count.

namespace osteon::detail {

namespace {

/// A token from the file for a message: at most 32 characters, non-printable bytes as '?'.
/// The next value token, possibly on a later line, skipping '#' comments; empty at the end.
std::string_view next_value(TextReader& text) {
  for (;;) {
    std::string_view token = text.next_token();
    if (token.empty() || token.front() != '#') return token;
    text.skip_line();
  }
}

/// The next token on this line, or empty at its end; a '#' comment ends the line (and is skipped,
/// with the line end, so the caller goes on with next_value).
std::string_view next_on_line(TextReader& text) {
  std::string_view token = text.next_token_on_line();
  if (token.empty() || token.front() != '#') return token;
  text.skip_line();
  return {};
}

struct OffKeyword {
  bool texture = false;  ///< ST: s t per vertex (ignored)
  bool colour = false;   ///< C: a colour per vertex (ignored)
  bool normal = false;   ///< N: nx ny nz per vertex
  bool four = false;     ///< 4: homogeneous x y z w
  bool ndim = false;     ///< n: the dimension follows the keyword
};

/// Parses "[ST][C][N][4][n]OFF"; false when `token` is not such a keyword.
bool parse_keyword(std::string_view token, OffKeyword* keyword) {
  if (token.size() < 3 || token.substr(token.size() - 3) != "OFF") return false;
  token.remove_suffix(3);
  auto take = [&token](std::string_view prefix) {
    if (token.substr(0, prefix.size()) != prefix) return false;
    token.remove_prefix(prefix.size());
    return true;
  };
  keyword->texture = take("ST");
  keyword->colour = take("C");
  keyword->normal = take("N");
  keyword->four = take("4");
  keyword->ndim = take("n");
  return token.empty();
}

Status bad_value(const std::string& source, const std::string& what, std::string_view token,
                 const TextReader& text) {
  if (token.empty()) {
    return error(ErrorCode::kInvalidData, source, "the file ends in " + what, text.where());
  }
  return error(ErrorCode::kInvalidData, source,
               what + ": " + quote_token(token) + " is not a number", text.where());
}

Status read_count(TextReader& text, std::string_view token, const std::string& source,
                  const char* what, uint64_t* count) {
  int64_t value = 0;
  if (token.empty()) {
    return error(ErrorCode::kInvalidData, source, std::string("the file ends before the ") + what,
                 text.where());
  }
  if (!parse_int(token, &value) || value < 0) {
    return error(ErrorCode::kInvalidData, source,
                 std::string("bad ") + what + " " + quote_token(token) + " (expected a count >= 0)",
                 text.where());
  }
  *count = static_cast<uint64_t>(value);
  return {};
}

Status read_vec3(TextReader& text, const std::string& source, const std::string& what, Vec3* out) {
  float* values[3] = {&out->x, &out->y, &out->z};
  for (float* v : values) {
    std::string_view token = next_value(text);
    if (!parse_float(token, v)) return bad_value(source, what, token, text);
  }
  return {};
}

}  // namespace

Status parse_off(const uint8_t* data, size_t size, const std::string& source,
                 const ReadOptions& options, Scene* scene) {
  (void)options;
  TextReader text(data, size);

  // The keyword (optional) and the counts.
  OffKeyword keyword;
  std::string_view token = next_value(text);
  if (token.empty()) return error(ErrorCode::kInvalidData, source, "the file is empty", "line 1");
  int64_t probe = 0;
  bool headerless = parse_int(token, &probe);
  if (!headerless) {
    if (!parse_keyword(token, &keyword)) {
      return error(ErrorCode::kInvalidData, source,
                   "not an OFF file: it begins with " + quote_token(token), text.where());
    }
    token = next_on_line(text);
    if (token == "BINARY") {
      return error(ErrorCode::kUnsupported, source, "binary OFF is not supported", text.where());
    }
    if (keyword.four) {
      return error(ErrorCode::kUnsupported, source, "4-dimensional OFF (4OFF) is not supported",
                   text.where());
    }
    if (keyword.ndim) {
      if (token.empty()) token = next_value(text);
      uint64_t dimension = 0;
      OSTEON_RETURN_IF_ERROR(read_count(text, token, source, "nOFF dimension", &dimension));
      if (dimension != 3) {
        return error(ErrorCode::kUnsupported, source,
                     "nOFF of dimension " + std::to_string(dimension) + " is not supported",
                     text.where());
      }
      token = next_on_line(text);
    }
    if (token.empty()) token = next_value(text);
  }
  uint64_t vertex_count = 0, face_count = 0;
  OSTEON_RETURN_IF_ERROR(read_count(text, token, source, "vertex count", &vertex_count));
  OSTEON_RETURN_IF_ERROR(read_count(text, next_value(text), source, "face count", &face_count));
  std::string counts_where = text.where();
  text.skip_line();  // the edge count, which nobody needs, when present

  // Every vertex needs three values and every face one, each value two bytes but the last.
  uint64_t budget = uint64_t{text.remaining()} + 1;
  if (vertex_count > budget / 6 || face_count > (budget - 6 * vertex_count) / 2) {
    return error(ErrorCode::kInvalidData, source,
                 std::to_string(vertex_count) + " vertices and " + std::to_string(face_count) +
                     " faces declared, more than the " + std::to_string(text.remaining()) +
                     " bytes that follow can hold",
                 counts_where);
  }
  if (vertex_count > UINT32_MAX) {
    return error(ErrorCode::kUnsupported, source,
                 std::to_string(vertex_count) + " vertices; at most 4294967295 can be indexed",
                 counts_where);
  }

  Mesh mesh;
  mesh.positions.reserve(static_cast<size_t>(vertex_count));
  if (keyword.normal) mesh.normals.reserve(static_cast<size_t>(vertex_count));
  // A triangle "3 a b c" takes at least eight bytes.
  mesh.indices.reserve(3 * static_cast<size_t>(std::min<uint64_t>(face_count, budget / 8)));

  bool normals_finite = true;
  for (uint64_t i = 0; i < vertex_count; ++i) {
    Vec3 p;
    std::string what = "vertex " + std::to_string(i);
    OSTEON_RETURN_IF_ERROR(read_vec3(text, source, what, &p));
    if (!is_finite(p)) return non_finite_error(source, i, text.where());
    mesh.positions.push_back(p);
    if (keyword.normal) {
      Vec3 n;
      OSTEON_RETURN_IF_ERROR(read_vec3(text, source, "the normal of " + what, &n));
      normals_finite = normals_finite && is_finite(n);
      mesh.normals.push_back(n);
    }
    text.skip_line();  // a colour, texture coordinates, a comment
  }

  std::vector<uint32_t> corners;
  uint64_t short_faces = 0;
  for (uint64_t f = 0; f < face_count; ++f) {
    std::string_view count_token = next_value(text);
    int64_t n = 0;
    if (count_token.empty()) {
      return error(ErrorCode::kInvalidData, source,
                   "the file ends after " + std::to_string(f) + " of " +
                       std::to_string(face_count) + " faces",
                   text.where());
    }
    if (!parse_int(count_token, &n) || n < 0 ||
        static_cast<uint64_t>(n) > (uint64_t{text.remaining()} + 1) / 2) {
      return error(ErrorCode::kInvalidData, source,
                   "face " + std::to_string(f) + ": bad corner count " + quote_token(count_token),
                   text.where());
    }
    corners.clear();
    for (int64_t k = 0; k < n; ++k) {
      std::string_view index_token = next_value(text);
      int64_t index = 0;
      if (index_token.empty()) {
        return error(ErrorCode::kInvalidData, source, "the file ends in face " + std::to_string(f),
                     text.where());
      }
      if (!parse_int(index_token, &index)) {
        return error(ErrorCode::kInvalidData, source,
                     "face " + std::to_string(f) + ": " + quote_token(index_token) +
                         " is not a vertex index",
                     text.where());
      }
      if (index < 0 || static_cast<uint64_t>(index) >= vertex_count) {
        return error(ErrorCode::kInvalidData, source,
                     "face " + std::to_string(f) + ": vertex index " + std::to_string(index) +
                         " out of range (" + std::to_string(vertex_count) + " vertices)",
                     text.where());
      }
      corners.push_back(static_cast<uint32_t>(index));
    }
    text.skip_line();  // a face colour, a comment
    if (corners.size() >= 3) {
      add_polygon_fan(mesh, corners.data(), corners.size());
    } else {
      ++short_faces;
    }
  }
  if (mesh.indices.empty()) {
    std::string what = "no triangles";
    if (short_faces > 0) {
      what += ": all " + std::to_string(short_faces) + " faces have fewer than 3 corners";
    }
    return error(ErrorCode::kInvalidData, source, what);
  }
  if (!normals_finite) mesh.normals.clear();
  mesh.stored_vertices = static_cast<size_t>(vertex_count);
  scene->parts.push_back(std::move(mesh));
  return {};
}

}  // namespace osteon::detail
