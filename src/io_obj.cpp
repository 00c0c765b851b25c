// SPDX-License-Identifier: Apache-2.0
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "core/byte_io.hpp"
#include "core/release.hpp"
#include "io_internal.hpp"

// Based on: Wavefront "Object Files (.obj)", Appendix B1 of the Advanced Visualizer manual:
// "v x y z [w]", "vn i j k", "vt u [v [w]]", "f v1[/vt1][/vn1] ..." with 1-based indices or
// negative ones counting back from the last element defined, "g name" and "o name", '\' to
// continue a line, '#' comments.
//
// What the reader takes, and its choices:
// - v: x y z (must be finite); anything after them on the line (w, a colour) is ignored;
// - vn: normals; vt: counted (a face's texture index must be in range), otherwise ignored;
// - f (and the old fo): corners "i", "i/t", "i//n", "i/t/n"; fan-triangulated in file order; a
//   face of fewer than 3 corners gives no triangle; a positive index may name a vertex defined
//   further down the file (checked at the end), a negative one counts back from the line it is on;
// - "g name" and "o name" start a part named by the rest of the line (a file without them gives
//   one part with an empty name); a later "g" with a name seen before adds to that part again, as
//   OBJ groups are sets; groups without faces give no part; parts come in the order of their
//   first face;
// - positions are shared by all groups in OBJ, so each part gets only the positions its faces
//   use, numbered in the order its faces first use them; stored_vertices is that count (positions
//   no face uses belong to no part and are dropped);
// - a part keeps normals only when every corner of its faces names one and every position gets
//   the same normal (by value) from all its corners, all finite; otherwise it has none;
// - mtllib, usemtl, s, l, p, curves and any unknown keyword are skipped.

namespace osteon::detail {

namespace {

constexpr uint32_t kUnset = UINT32_MAX;

/// A token from the file for a message: at most 32 characters, non-printable bytes as '?'.
/// The next token on the logical line: a lone '\' at the end of a line continues it on the next.
std::string_view next_token(TextReader& text) {
  std::string_view token = text.next_token_on_line();
  while (token == "\\") {
    text.skip_line();
    token = text.next_token_on_line();
  }
  return token;
}

struct ObjPart {
  std::string name;
  std::vector<uint32_t> positions;  ///< per triangle corner: the index into the file's positions
  std::vector<uint32_t> normals;    ///< per triangle corner: the index into the file's normals
  bool all_normals = true;  ///< every corner so far named a normal (else `normals` is empty)
};

/// The largest positive index that named an element not yet defined on its line; checked at the
/// end, when every element has been defined.
struct ForwardReference {
  uint64_t largest = 0;  ///< 0-based; valid when `where` is not empty
  std::string where;
  void note(uint64_t index, const TextReader& text) {
    if (where.empty() || index > largest) {
      largest = index;
      where = text.where();
    }
  }
  Status check(uint64_t defined, const char* kind, const std::string& source) const {
    if (where.empty() || largest < defined) return {};
    return error(ErrorCode::kInvalidData, source,
                 std::string(kind) + " index " + std::to_string(largest + 1) +
                     " out of range (the file defines " + std::to_string(defined) + ")",
                 where);
  }
};

/// Turns an OBJ index (1-based, or negative counting back from the `defined` elements so far)
/// into a 0-based one.
Status resolve(std::string_view token, size_t defined, const char* kind, const TextReader& text,
               const std::string& source, ForwardReference* forward, uint32_t* out) {
  int64_t raw = 0;
  if (!parse_int(token, &raw)) {
    return error(ErrorCode::kInvalidData, source,
                 std::string("bad ") + kind + " index " + quote_token(token), text.where());
  }
  if (raw == 0) {
    return error(ErrorCode::kInvalidData, source,
                 std::string(kind) + " index 0 (OBJ indices start at 1)", text.where());
  }
  if (raw < 0) {
    if (raw < -static_cast<int64_t>(defined)) {
      return error(ErrorCode::kInvalidData, source,
                   std::string("relative ") + kind + " index " + std::to_string(raw) +
                       " out of range (" + std::to_string(defined) + " defined so far)",
                   text.where());
    }
    *out = static_cast<uint32_t>(static_cast<int64_t>(defined) + raw);
    return {};
  }
  if (raw > static_cast<int64_t>(UINT32_MAX) - 1) {
    return error(ErrorCode::kInvalidData, source,
                 std::string(kind) + " index " + std::to_string(raw) + " out of range",
                 text.where());
  }
  *out = static_cast<uint32_t>(raw - 1);
  if (*out >= defined) forward->note(*out, text);
  return {};
}

Status read_vec3(TextReader& text, const std::string& source, const char* what, Vec3* out) {
  float* values[3] = {&out->x, &out->y, &out->z};
  for (float* v : values) {
    std::string_view token = next_token(text);
    if (!parse_float(token, v)) {
      return error(ErrorCode::kInvalidData, source,
                   token.empty()
                       ? std::string(what) + " needs three numbers"
                       : std::string(what) + ": " + quote_token(token) + " is not a number",
                   text.where());
    }
  }
  return {};
}

class ObjReader {
 public:
  explicit ObjReader(const std::string& source) : source_(source) {}

  Status read(TextReader& text);
  Status finish(Scene* scene);

 private:
  Status read_face(TextReader& text);
  ObjPart& current_part();

  const std::string& source_;
  std::vector<Vec3> positions_;
  std::vector<Vec3> normals_;
  size_t texcoords_ = 0;
  ForwardReference forward_positions_, forward_normals_, forward_texcoords_;
  std::vector<ObjPart> parts_;
  std::unordered_map<std::string, size_t> part_of_name_;
  std::string group_;          ///< the name the last g or o gave
  size_t current_ = SIZE_MAX;  ///< the part faces go to; SIZE_MAX until the group's first face
  std::vector<uint32_t> corner_positions_, corner_normals_;  ///< one face, reused
  uint64_t short_faces_ = 0;
};

ObjPart& ObjReader::current_part() {
  if (current_ == SIZE_MAX) {
    auto [it, added] = part_of_name_.try_emplace(group_, parts_.size());
    if (added) {
      parts_.emplace_back();
      parts_.back().name = group_;
    }
    current_ = it->second;
  }
  return parts_[current_];
}

Status ObjReader::read(TextReader& text) {
  while (!text.at_end()) {
    std::string_view key = text.next_token_on_line();
    if (key == "v") {
      Vec3 p;
      OSTEON_RETURN_IF_ERROR(read_vec3(text, source_, "v", &p));
      if (!is_finite(p)) return non_finite_error(source_, positions_.size(), text.where());
      if (positions_.size() >= UINT32_MAX - 1) {
        return error(ErrorCode::kUnsupported, source_, "more than 4294967294 vertices",
                     text.where());
      }
      positions_.push_back(p);
    } else if (key == "vn") {
      Vec3 n;
      OSTEON_RETURN_IF_ERROR(read_vec3(text, source_, "vn", &n));
      if (normals_.size() >= UINT32_MAX - 1) {
        return error(ErrorCode::kUnsupported, source_, "more than 4294967294 normals",
                     text.where());
      }
      normals_.push_back(n);
    } else if (key == "vt") {
      ++texcoords_;
    } else if (key == "f" || key == "fo") {
      OSTEON_RETURN_IF_ERROR(read_face(text));
    } else if (key == "g" || key == "o") {
      text.skip_blanks();
      group_ = std::string(text.rest_of_line());
      current_ = SIZE_MAX;
      continue;  // rest_of_line moved to the next line already
    }
    // Comments, blank lines, unknown keywords, and what follows the values on a line.
    text.skip_line();
  }
  OSTEON_RETURN_IF_ERROR(forward_positions_.check(positions_.size(), "vertex", source_));
  OSTEON_RETURN_IF_ERROR(forward_normals_.check(normals_.size(), "normal", source_));
  OSTEON_RETURN_IF_ERROR(forward_texcoords_.check(texcoords_, "texture", source_));
  return {};
}

Status ObjReader::read_face(TextReader& text) {
  corner_positions_.clear();
  corner_normals_.clear();
  bool with_normals = true;
  for (;;) {
    std::string_view token = next_token(text);
    if (token.empty() || token.front() == '#') break;
    // "i", "i/t", "i//n" or "i/t/n".
    size_t slash = token.find('/');
    std::string_view position = token.substr(0, slash), texture, normal;
    bool bad = position.empty();
    if (slash != std::string_view::npos) {
      std::string_view rest = token.substr(slash + 1);
      slash = rest.find('/');
      texture = rest.substr(0, slash);
      if (slash != std::string_view::npos) normal = rest.substr(slash + 1);
      bad = bad || normal.find('/') != std::string_view::npos;
    }
    if (bad) {
      return error(ErrorCode::kInvalidData, source_, "bad face corner " + quote_token(token),
                   text.where());
    }
    uint32_t index = 0;
    OSTEON_RETURN_IF_ERROR(
        resolve(position, positions_.size(), "vertex", text, source_, &forward_positions_, &index));
    corner_positions_.push_back(index);
    if (!texture.empty()) {
      OSTEON_RETURN_IF_ERROR(
          resolve(texture, texcoords_, "texture", text, source_, &forward_texcoords_, &index));
    }
    if (!normal.empty()) {
      OSTEON_RETURN_IF_ERROR(
          resolve(normal, normals_.size(), "normal", text, source_, &forward_normals_, &index));
      corner_normals_.push_back(index);
    } else {
      with_normals = false;
    }
  }
  size_t n = corner_positions_.size();
  if (n < 3) {
    ++short_faces_;
    return {};
  }
  ObjPart& part = current_part();
  for (size_t i = 1; i + 1 < n; ++i) {
    part.positions.insert(part.positions.end(),
                          {corner_positions_[0], corner_positions_[i], corner_positions_[i + 1]});
  }
  if (part.all_normals && !with_normals) {
    part.all_normals = false;
    release(part.normals);
  }
  if (part.all_normals) {
    for (size_t i = 1; i + 1 < n; ++i) {
      part.normals.insert(part.normals.end(),
                          {corner_normals_[0], corner_normals_[i], corner_normals_[i + 1]});
    }
  }
  return {};
}

Status ObjReader::finish(Scene* scene) {
  std::vector<uint32_t> local(positions_.size(), kUnset);  // file position -> part position
  std::vector<uint32_t> used;                              // part position -> file position
  size_t parts_added = 0;
  for (ObjPart& part : parts_) {
    Mesh mesh;
    mesh.name = part.name;
    used.clear();
    mesh.indices.resize(part.positions.size());
    for (size_t c = 0; c < part.positions.size(); ++c) {
      uint32_t p = part.positions[c];
      if (local[p] == kUnset) {
        local[p] = static_cast<uint32_t>(used.size());
        used.push_back(p);
      }
      mesh.indices[c] = local[p];
    }
    mesh.positions.resize(used.size());
    for (size_t i = 0; i < used.size(); ++i) mesh.positions[i] = positions_[used[i]];
    if (part.all_normals) {
      // Normals only when each position gets one normal from all its corners.
      mesh.normals.resize(used.size());
      std::vector<bool> set(used.size(), false);
      bool consistent = true;
      for (size_t c = 0; c < part.normals.size() && consistent; ++c) {
        uint32_t v = mesh.indices[c];
        const Vec3& n = normals_[part.normals[c]];
        if (!is_finite(n)) {
          consistent = false;
        } else if (!set[v]) {
          set[v] = true;
          mesh.normals[v] = n;
        } else if (!(mesh.normals[v] == n)) {
          consistent = false;
        }
      }
      if (!consistent) mesh.normals.clear();
    }
    for (uint32_t p : used) local[p] = kUnset;
    mesh.stored_vertices = used.size();
    part = ObjPart();  // frees the corners before the next part is built
    scene->parts.push_back(std::move(mesh));
    ++parts_added;
  }
  if (parts_added == 0) {
    std::string what = "no triangles";
    if (short_faces_ > 0) {
      what += ": all " + std::to_string(short_faces_) + " faces have fewer than 3 corners";
    }
    return error(ErrorCode::kInvalidData, source_, what);
  }
  return {};
}

}  // namespace

Status parse_obj(const uint8_t* data, size_t size, const std::string& source,
                 const ReadOptions& options, Scene* scene) {
  (void)options;
  // A UTF-8 byte order mark would otherwise hide the first keyword.
  if (size >= 3 && std::memcmp(data, "\xEF\xBB\xBF", 3) == 0) {
    data += 3;
    size -= 3;
  }
  TextReader text(data, size);
  ObjReader reader(source);
  OSTEON_RETURN_IF_ERROR(reader.read(text));
  return reader.finish(scene);
}

}  // namespace osteon::detail
