// SPDX-License-Identifier: Apache-2.0
// glTF 2.0 reader: .gltf (JSON with data: URI or external buffers) and .glb, geometry only.
//
// Based on: the glTF 2.0 specification (Khronos, 2021): the GLB container, accessors and sparse
// accessors with their bounds rules, node transforms (TRS = T * R * S; a negative determinant makes
// the winding clockwise), primitive modes; and the KHR_mesh_quantization extension.
// EXT_meshopt_compression, KHR_meshopt_compression and KHR_draco_mesh_compression are decoded
// first (io_gltf_compressed.cpp).
// tinygltf (Debian's libtinygltf 2.7.0) parses the JSON; everything it hands back is validated
// again here, and a few of its habits are fenced off:
//   - the GLB container is checked before tinygltf sees it (2.7.0 forgets the BIN chunk's 8-byte
//     header when checking that the chunk fits, and takes a 32-bit length);
//   - JSON nested deeper than kMaxJsonDepth is refused first (tinygltf copies `extras` and
//     `extensions` recursively, so deep nesting would overflow the stack);
//   - images are never decoded: the image loader is a no-op;
//   - files are read only through our callbacks: none when the glTF comes from memory (empty
//     base_dir), otherwise regular files inside base_dir only (tinygltf also looks in the
//     working directory and follows absolute paths and "..");
//   - tinygltf may throw (std::vector::at, bad_alloc): every call is wrapped, nothing escapes;
//   - its warnings are dropped and its errors become the Status message; nothing is printed.
//
// What becomes a part: the default scene (else scene 0, else every root node) is walked; each
// node with a mesh gives one part named by the node's name (empty if none), holding all the
// triangle primitives of its mesh (TRIANGLES; TRIANGLE_STRIP and TRIANGLE_FAN unrolled; points
// and lines skipped), transformed by the node's world matrix (composed in double precision).
// Normals go through the inverse-transpose and are renormalised. When the world matrix mirrors
// (determinant < 0) each triangle's winding is reversed so its front still faces outward, as the
// spec defines. Strip triangles that repeat an index are dropped (strips repeat indices
// on purpose to join); TRIANGLES and fans keep theirs for diagnose() to report.
// A node whose mesh gives no triangle gives no part. The node hierarchy must be a tree: a node
// reached twice (a cycle, or two parents) is an error. External files inside base_dir that images
// name may be read (tinygltf reads them), but never decoded.
// EXT_mesh_gpu_instancing: a node with instances gives one part per instance (the instance's
// TRANSLATION * ROTATION * SCALE applied before the node's world matrix; the winding reversed
// where that product mirrors), named from the node's extras when osteon export wrote them
// (extras.osteon.instances[i].name, in instance order), else "<node name>#<i>". A node's part
// name is extras.osteon.name when present (osteon export keeps the package's part name there and
// the display name in the node's name), else the node's name.
// Known approximations: skins and morph targets are not applied (the rest pose is read).
// Output is capped (see kExpansionFactor) against files that instance one mesh millions of
// times.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include <tiny_gltf.h>

#include "core/byte_io.hpp"
#include "io_internal.hpp"

namespace osteon::detail {
namespace {

namespace fs = std::filesystem;

/// Deeper JSON is refused (glTF itself needs about 8 levels).
constexpr size_t kMaxJsonDepth = 128;
/// Instancing (many nodes sharing a mesh) may multiply the geometry; the output is capped at
/// kExpansionFloorBytes + kExpansionFactor x the file size, so a small file cannot demand
/// terabytes.
constexpr uint64_t kExpansionFloorBytes = uint64_t{256} << 20;
constexpr uint64_t kExpansionFactor = 64;

constexpr uint32_t kGlbMagic = 0x46546C67;   // "glTF"
constexpr uint32_t kChunkJson = 0x4E4F534A;  // "JSON"
constexpr uint32_t kChunkBin = 0x004E4942;   // "BIN\0"

// ---- the container and the JSON --------------------------------------------------------------

struct GlbLayout {
  size_t length = 0;  ///< the GLB's own length (<= the file size)
  size_t json_offset = 0;
  size_t json_size = 0;
  size_t bin_offset = 0;  ///< the BIN chunk's data (bin_size 0: none)
  size_t bin_size = 0;
};

Status check_glb(const uint8_t* data, size_t size, const std::string& source, GlbLayout* out) {
  ByteReader r(data, size);
  uint32_t magic = 0, version = 0, length = 0, json_length = 0, json_type = 0;
  if (!r.read_le(&magic) || !r.read_le(&version) || !r.read_le(&length)) {
    return error(ErrorCode::kInvalidData, source,
                 "truncated GLB header: " + std::to_string(size) + " of 12 bytes", at_byte(size));
  }
  if (magic != kGlbMagic) {
    return error(ErrorCode::kInvalidData, source, "not a GLB file (bad magic)", "byte 0");
  }
  if (version != 2) {
    return error(ErrorCode::kUnsupported, source,
                 "GLB version " + std::to_string(version) + " is not supported (only 2)", "byte 4");
  }
  if (length > size) {
    return error(ErrorCode::kInvalidData, source,
                 "the GLB header declares " + std::to_string(length) + " bytes, the file has " +
                     std::to_string(size),
                 "byte 8");
  }
  ByteReader g(data, length);  // chunks must lie inside the declared length
  if (!g.seek(12) || !g.read_le(&json_length) || !g.read_le(&json_type)) {
    return error(ErrorCode::kInvalidData, source, "truncated GLB: no room for the JSON chunk",
                 "byte 12");
  }
  if (json_type != kChunkJson) {
    return error(ErrorCode::kInvalidData, source, "the first GLB chunk is not JSON", "byte 16");
  }
  if (json_length > g.remaining()) {
    return error(ErrorCode::kInvalidData, source,
                 "the JSON chunk declares " + std::to_string(json_length) + " bytes, room for " +
                     std::to_string(g.remaining()),
                 "byte 12");
  }
  out->length = length;
  out->json_offset = 20;
  out->json_size = json_length;
  (void)g.skip(json_length);
  if (g.remaining() == 0) return {};  // no BIN chunk
  size_t bin_at = g.offset();
  uint32_t bin_length = 0, bin_type = 0;
  if (!g.read_le(&bin_length) || !g.read_le(&bin_type)) {
    return error(ErrorCode::kInvalidData, source, "truncated GLB chunk header", at_byte(bin_at));
  }
  if (bin_type != kChunkBin) {
    return error(ErrorCode::kInvalidData, source, "the second GLB chunk is not BIN",
                 at_byte(bin_at + 4));
  }
  if (bin_length > g.remaining()) {
    return error(ErrorCode::kInvalidData, source,
                 "the BIN chunk declares " + std::to_string(bin_length) + " bytes, room for " +
                     std::to_string(g.remaining()),
                 at_byte(bin_at));
  }
  if (bin_length < 4 || bin_length % 4 != 0) {
    return error(
        ErrorCode::kInvalidData, source,
        "the BIN chunk's length " + std::to_string(bin_length) + " is not a positive multiple of 4",
        at_byte(bin_at));
  }
  out->bin_offset = bin_at + 8;
  out->bin_size = bin_length;
  return {};
}

/// The offset of the first bracket nested deeper than `limit`, or npos.
size_t too_deep_at(const uint8_t* p, size_t n, size_t limit) {
  size_t depth = 0;
  bool in_string = false;
  for (size_t i = 0; i < n; ++i) {
    uint8_t c = p[i];
    if (in_string) {
      if (c == '\\') {
        ++i;
      } else if (c == '"') {
        in_string = false;
      }
    } else if (c == '"') {
      in_string = true;
    } else if (c == '{' || c == '[') {
      if (++depth > limit) return i;
    } else if ((c == '}' || c == ']') && depth > 0) {
      --depth;
    }
  }
  return std::string_view::npos;
}

// ---- tinygltf's file system and image callbacks -----------------------------------------------

struct FilePolicy {
  fs::path base;  ///< canonical base_dir; empty: no file may be read
  uint64_t max_bytes = 0;
  std::string refused;  ///< the first path refused, for the message
};

/// The canonical form of `path` when it is a regular file inside the policy's folder.
bool allowed_path(const std::string& path, FilePolicy* policy, fs::path* out) {
  std::error_code ec;
  if (!policy->base.empty()) {
    fs::path canonical = fs::weakly_canonical(fs::path(path), ec);
    if (!ec && fs::is_regular_file(canonical, ec) && !ec) {
      fs::path relative = canonical.lexically_relative(policy->base);
      if (!relative.empty() && *relative.begin() != ".." && relative.is_relative()) {
        *out = canonical;
        return true;
      }
    }
  }
  if (policy->refused.empty()) policy->refused = path;
  return false;
}

bool policy_file_exists(const std::string& path, void* user) {
  fs::path canonical;
  return allowed_path(path, static_cast<FilePolicy*>(user), &canonical);
}

std::string policy_expand(const std::string& path, void*) {
  return path;
}

bool policy_read(std::vector<unsigned char>* out, std::string* err, const std::string& path,
                 void* user) {
  auto* policy = static_cast<FilePolicy*>(user);
  fs::path canonical;
  if (!allowed_path(path, policy, &canonical)) return false;
  std::error_code ec;
  uint64_t bytes = fs::file_size(canonical, ec);
  if (ec || bytes > policy->max_bytes) {
    if (err) *err += "cannot read " + path + " (or it is over the size limit)";
    return false;
  }
  std::ifstream in(canonical, std::ios::binary);
  out->resize(static_cast<size_t>(bytes));
  if (!in.read(reinterpret_cast<char*>(out->data()), static_cast<std::streamsize>(bytes))) {
    if (err) *err += "cannot read " + path;
    return false;
  }
  return true;
}

bool policy_write(std::string*, const std::string&, const std::vector<unsigned char>&, void*) {
  return false;
}

bool skip_image(tinygltf::Image*, const int, std::string*, std::string*, int, int,
                const unsigned char*, int, void*) {
  return true;
}

/// tinygltf's multi-line error text as one line ("first; second").
std::string one_line(const std::string& text) {
  std::string out;
  size_t start = 0;
  while (start < text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    std::string_view line(text.data() + start, end - start);
    while (!line.empty() && (line.back() == ' ' || line.back() == '\r')) line.remove_suffix(1);
    if (!line.empty()) {
      if (!out.empty()) out += "; ";
      out += line;
    }
    start = end + 1;
  }
  return out.empty() ? "unknown error" : out;
}

// ---- extensions --------------------------------------------------------------------------------

/// Required extensions that do not change the geometry, or that this reader decodes.
bool extension_ok(const std::string& name) {
  static const char* kPrefixes[] = {"KHR_materials_", "KHR_texture_", "EXT_texture_",
                                    "MSFT_texture_",  "KHR_lights_",  "EXT_lights_"};
  for (const char* prefix : kPrefixes) {
    if (name.rfind(prefix, 0) == 0) return true;
  }
  return name == "KHR_mesh_quantization" || name == "EXT_mesh_gpu_instancing" ||
         name == "KHR_xmp_json_ld" ||
         name == "KHR_materials_variants";
}

// ---- matrices (column-major, as glTF stores them) ------------------------------------------

/// The node's local matrix: `matrix`, or T * R * S.
Status local_matrix(const tinygltf::Node& node, int index, const std::string& source, Mat4* out) {
  std::string where = "node " + std::to_string(index);
  auto bad_size = [&](const char* what, size_t got, size_t want) {
    return error(
        ErrorCode::kInvalidData, source,
        std::string(what) + " has " + std::to_string(got) + " numbers, not " + std::to_string(want),
        where);
  };
  Mat4 m = kIdentityMatrix;
  if (!node.matrix.empty()) {
    if (node.matrix.size() != 16) return bad_size("matrix", node.matrix.size(), 16);
    std::copy(node.matrix.begin(), node.matrix.end(), m.begin());
  } else {
    if (!node.translation.empty() && node.translation.size() != 3) {
      return bad_size("translation", node.translation.size(), 3);
    }
    if (!node.rotation.empty() && node.rotation.size() != 4) {
      return bad_size("rotation", node.rotation.size(), 4);
    }
    if (!node.scale.empty() && node.scale.size() != 3) {
      return bad_size("scale", node.scale.size(), 3);
    }
    double x = 0, y = 0, z = 0, w = 1;
    if (!node.rotation.empty()) {
      x = node.rotation[0], y = node.rotation[1], z = node.rotation[2], w = node.rotation[3];
      double norm = std::sqrt(x * x + y * y + z * z + w * w);
      if (!(norm > 1e-12) || !std::isfinite(norm)) {
        return error(ErrorCode::kInvalidData, source, "rotation is not a unit quaternion", where);
      }
      x /= norm, y /= norm, z /= norm, w /= norm;
    }
    // R from the quaternion (x, y, z, w), columns scaled by S, translation in column 3.
    double sx = 1, sy = 1, sz = 1;
    if (!node.scale.empty()) sx = node.scale[0], sy = node.scale[1], sz = node.scale[2];
    m = {(1 - 2 * (y * y + z * z)) * sx,
         (2 * (x * y + z * w)) * sx,
         (2 * (x * z - y * w)) * sx,
         0,
         (2 * (x * y - z * w)) * sy,
         (1 - 2 * (x * x + z * z)) * sy,
         (2 * (y * z + x * w)) * sy,
         0,
         (2 * (x * z + y * w)) * sz,
         (2 * (y * z - x * w)) * sz,
         (1 - 2 * (x * x + y * y)) * sz,
         0,
         0,
         0,
         0,
         1};
    if (!node.translation.empty()) {
      m[12] = node.translation[0], m[13] = node.translation[1], m[14] = node.translation[2];
    }
  }
  for (double v : m) {
    if (!std::isfinite(v)) {
      return error(ErrorCode::kInvalidData, source, "the transform is not finite", where);
    }
  }
  *out = m;
  return {};
}

// ---- accessors ---------------------------------------------------------------------------------

enum class Role { kPosition, kNormal, kIndices, kTranslation, kRotation, kScale };

const char* role_name(Role role) {
  switch (role) {
    case Role::kPosition:
      return "POSITION";
    case Role::kNormal:
      return "NORMAL";
    case Role::kIndices:
      return "indices";
    case Role::kTranslation:
      return "TRANSLATION";
    case Role::kRotation:
      return "ROTATION";
    case Role::kScale:
      return "SCALE";
  }
  return "";
}

size_t component_bytes(int component_type) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
      return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT:
      return 4;
    default:
      return 0;
  }
}

/// Which component types the spec (with KHR_mesh_quantization) allows for a role.
bool component_allowed(Role role, int type, bool normalized) {
  switch (role) {
    case Role::kPosition:
      return type == TINYGLTF_COMPONENT_TYPE_FLOAT ||
             (type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT && component_bytes(type) != 0);
    case Role::kNormal:
      return type == TINYGLTF_COMPONENT_TYPE_FLOAT ||
             (normalized &&
              (type == TINYGLTF_COMPONENT_TYPE_BYTE || type == TINYGLTF_COMPONENT_TYPE_SHORT));
    case Role::kIndices:
      return !normalized && (type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                             type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT ||
                             type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
    // EXT_mesh_gpu_instancing (with KHR_mesh_quantization: byte and short ones too).
    case Role::kTranslation:
    case Role::kScale:
      return type == TINYGLTF_COMPONENT_TYPE_FLOAT ||
             (type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT && component_bytes(type) != 0);
    case Role::kRotation:
      return type == TINYGLTF_COMPONENT_TYPE_FLOAT ||
             (normalized &&
              (type == TINYGLTF_COMPONENT_TYPE_BYTE || type == TINYGLTF_COMPONENT_TYPE_SHORT));
  }
  return false;
}

/// One little-endian component as a double, normalised as the spec says.
double load_component(const uint8_t* p, int type, bool normalized) {
  constexpr auto kLittle = std::endian::little;
  switch (type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
      double v = static_cast<int8_t>(p[0]);
      return normalized ? std::max(v / 127.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return normalized ? p[0] / 255.0 : p[0];
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      double v = ByteReader::load<int16_t>(p, kLittle);
      return normalized ? std::max(v / 32767.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      double v = ByteReader::load<uint16_t>(p, kLittle);
      return normalized ? v / 65535.0 : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
      return ByteReader::load<uint32_t>(p, kLittle);
    case TINYGLTF_COMPONENT_TYPE_FLOAT:
      return ByteReader::load<float>(p, kLittle);
    default:
      return 0;
  }
}

class Reader {
 public:
  Reader(const tinygltf::Model& model, const std::string& source, size_t file_size)
      : model_(model), source_(source), file_size_(file_size) {}

  /// The bytes [offset, offset + count * stride) of a buffer view, as a pointer, after checking
  /// that the view lies in its buffer and the range in the view (elements of `element` bytes
  /// every `stride` bytes). `what` names the accessor for messages.
  Status view_range(int view_index, uint64_t offset, uint64_t count, uint64_t element,
                    uint64_t stride, const std::string& what, const uint8_t** out) const {
    if (view_index < 0 || static_cast<size_t>(view_index) >= model_.bufferViews.size()) {
      return fail("bufferView " + std::to_string(view_index) + " does not exist", what);
    }
    const tinygltf::BufferView& view = model_.bufferViews[static_cast<size_t>(view_index)];
    std::string view_where = "bufferView " + std::to_string(view_index);
    if (view.buffer < 0 || static_cast<size_t>(view.buffer) >= model_.buffers.size()) {
      return fail("buffer " + std::to_string(view.buffer) + " does not exist", view_where);
    }
    const std::vector<unsigned char>& buffer =
        model_.buffers[static_cast<size_t>(view.buffer)].data;
    if (view.byteOffset > buffer.size() || view.byteLength > buffer.size() - view.byteOffset) {
      return fail("bytes " + std::to_string(view.byteOffset) + " + " +
                      std::to_string(view.byteLength) + " overrun buffer " +
                      std::to_string(view.buffer) + " of " + std::to_string(buffer.size()) +
                      " bytes",
                  view_where);
    }
    uint64_t length = view.byteLength;
    bool fits = count == 0 || (offset <= length && element <= length - offset &&
                               count - 1 <= (length - offset - element) / stride);
    if (!fits) {
      return fail(std::to_string(count) + " elements of " + std::to_string(element) +
                      " bytes every " + std::to_string(stride) + " from byte " +
                      std::to_string(offset) + " overrun bufferView " + std::to_string(view_index) +
                      " of " + std::to_string(length) + " bytes",
                  what);
    }
    *out = buffer.data() + view.byteOffset + offset;
    return {};
  }

  /// Reads accessor `index` for `role` as count x components doubles.
  Status read(int index, Role role, std::vector<double>* out, size_t* count_out) const {
    std::string what = "accessor " + std::to_string(index);
    if (index < 0 || static_cast<size_t>(index) >= model_.accessors.size()) {
      return fail(std::string(role_name(role)) + " uses accessor " + std::to_string(index) +
                      ", which does not exist",
                  what);
    }
    const tinygltf::Accessor& a = model_.accessors[static_cast<size_t>(index)];
    const size_t components = role == Role::kIndices ? 1 : role == Role::kRotation ? 4 : 3;
    const int want_type = components == 1   ? TINYGLTF_TYPE_SCALAR
                          : components == 4 ? TINYGLTF_TYPE_VEC4
                                            : TINYGLTF_TYPE_VEC3;
    if (a.type != want_type) {
      return fail(std::string(role_name(role)) + " must be " +
                      (components == 1 ? "SCALAR" : components == 4 ? "VEC4" : "VEC3"),
                  what);
    }
    if (!component_allowed(role, a.componentType, a.normalized)) {
      return fail(std::string("componentType ") + std::to_string(a.componentType) +
                      (a.normalized ? " (normalized)" : "") + " is not allowed for " +
                      role_name(role),
                  what);
    }
    if (a.count == 0) return fail("count is 0", what);
    const size_t bytes = component_bytes(a.componentType);
    const size_t element = components * bytes;

    if (a.bufferView >= 0) {
      uint64_t stride = element;
      const tinygltf::BufferView* view = nullptr;
      if (static_cast<size_t>(a.bufferView) < model_.bufferViews.size()) {
        view = &model_.bufferViews[static_cast<size_t>(a.bufferView)];
        // Index views have no stride (spec 3.6.2.3); a vertex view's stride covers an element.
        if (role != Role::kIndices && view->byteStride != 0) {
          if (view->byteStride < element) {
            return fail("byteStride " + std::to_string(view->byteStride) +
                            " is less than the element size " + std::to_string(element),
                        "bufferView " + std::to_string(a.bufferView));
          }
          stride = view->byteStride;
        }
      }
      const uint8_t* p = nullptr;
      OSTEON_RETURN_IF_ERROR(
          view_range(a.bufferView, a.byteOffset, a.count, element, stride, what, &p));
      out->resize(a.count * components);
      for (size_t i = 0; i < a.count; ++i) {
        for (size_t c = 0; c < components; ++c) {
          (*out)[i * components + c] =
              load_component(p + i * stride + c * bytes, a.componentType, a.normalized);
        }
      }
    } else {
      // No bufferView: all zeros (then the sparse values). Its count is bounded by the file's
      // size so that a few bytes of JSON cannot ask for gigabytes.
      if (a.count > file_size_) {
        return fail("count " + std::to_string(a.count) +
                        " without a bufferView is more than the file's size allows",
                    what);
      }
      out->assign(a.count * components, 0.0);
    }

    if (a.sparse.isSparse) OSTEON_RETURN_IF_ERROR(apply_sparse(a, what, components, bytes, out));
    *count_out = a.count;
    return {};
  }

  Status fail(const std::string& what, const std::string& where) const {
    return error(ErrorCode::kInvalidData, source_, what, where);
  }

 private:
  Status apply_sparse(const tinygltf::Accessor& a, const std::string& what, size_t components,
                      size_t bytes, std::vector<double>* out) const {
    const auto& s = a.sparse;
    if (s.count < 1 || static_cast<size_t>(s.count) > a.count) {
      return fail(
          "sparse count " + std::to_string(s.count) + " is not in 1.." + std::to_string(a.count),
          what);
    }
    size_t index_bytes = component_bytes(s.indices.componentType);
    if (!component_allowed(Role::kIndices, s.indices.componentType, false)) {
      return fail("sparse indices have componentType " + std::to_string(s.indices.componentType),
                  what);
    }
    if (s.indices.byteOffset < 0 || s.values.byteOffset < 0) {
      return fail("sparse byteOffset is negative", what);
    }
    const uint8_t* indices = nullptr;
    const uint8_t* values = nullptr;
    uint64_t n = static_cast<uint64_t>(s.count);
    OSTEON_RETURN_IF_ERROR(view_range(s.indices.bufferView,
                                      static_cast<uint64_t>(s.indices.byteOffset), n, index_bytes,
                                      index_bytes, what + " sparse indices", &indices));
    uint64_t element = components * bytes;
    OSTEON_RETURN_IF_ERROR(view_range(s.values.bufferView,
                                      static_cast<uint64_t>(s.values.byteOffset), n, element,
                                      element, what + " sparse values", &values));
    double previous = -1;
    for (size_t i = 0; i < n; ++i) {
      double target = load_component(indices + i * index_bytes, s.indices.componentType, false);
      if (target <= previous || target >= static_cast<double>(a.count)) {
        return fail("sparse index " + std::to_string(static_cast<uint64_t>(target)) +
                        " is out of order or not below the count " + std::to_string(a.count),
                    what);
      }
      previous = target;
      size_t t = static_cast<size_t>(target);
      for (size_t c = 0; c < components; ++c) {
        (*out)[t * components + c] =
            load_component(values + i * element + c * bytes, a.componentType, a.normalized);
      }
    }
    return {};
  }

  const tinygltf::Model& model_;
  const std::string& source_;
  size_t file_size_;
};

// ---- nodes -------------------------------------------------------------------------------------

struct PartBuilder {
  Mesh mesh;
  bool normals_complete = true;
  /// (POSITION accessor, NORMAL accessor) -> the first vertex of its block in `mesh`, so that
  /// primitives sharing a vertex buffer share the vertices.
  std::map<std::pair<int, int>, std::pair<uint32_t, size_t>> blocks;
  /// Output bytes so far for the whole file, and the cap (see kExpansionFactor).
  uint64_t* emitted = nullptr;
  uint64_t budget = 0;
};

/// Counts `bytes` more output against the file's budget.
Status charge(PartBuilder* part, uint64_t bytes, const std::string& source,
              const std::string& where) {
  *part->emitted += bytes;
  if (*part->emitted > part->budget) {
    return error(ErrorCode::kInvalidData, source,
                 "the scene expands to more than " + std::to_string(part->budget) +
                     " bytes of geometry (instancing limit)",
                 where);
  }
  return {};
}

/// Appends the vertices of one (POSITION, NORMAL) pair, transformed by `world`.
Status add_vertices(const Reader& reader, int position_accessor, int normal_accessor,
                    const Mat4& world, const std::string& source, PartBuilder* part, uint32_t* base,
                    size_t* count) {
  std::vector<double> xyz;
  OSTEON_RETURN_IF_ERROR(reader.read(position_accessor, Role::kPosition, &xyz, count));
  Mesh& mesh = part->mesh;
  if (*count > std::numeric_limits<uint32_t>::max() - mesh.positions.size()) {
    return error(ErrorCode::kUnsupported, source, "more than 2^32 vertices in one part",
                 "accessor " + std::to_string(position_accessor));
  }
  *base = static_cast<uint32_t>(mesh.positions.size());
  mesh.positions.reserve(mesh.positions.size() + *count);
  for (size_t i = 0; i < *count; ++i) {
    const double* p = &xyz[3 * i];
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) {
      return non_finite_error(source, i, "accessor " + std::to_string(position_accessor));
    }
    const Vec3 v = to_float(transform_point(world, Vec3d{p[0], p[1], p[2]}));
    if (!is_finite(v)) {  // finite in the file, but not after the node transform
      return non_finite_error(source, i, "accessor " + std::to_string(position_accessor));
    }
    mesh.positions.push_back(v);
  }
  mesh.stored_vertices += *count;
  OSTEON_RETURN_IF_ERROR(
      charge(part, uint64_t{*count} * 24, source, "accessor " + std::to_string(position_accessor)));

  // Normals: through the inverse-transpose of the upper 3x3, which is its cofactor matrix divided
  // by its determinant (the sign matters: a mirror turns normals over too).
  double det = determinant3(world);
  if (normal_accessor < 0 || !part->normals_complete || det == 0 || !std::isfinite(det)) {
    part->normals_complete = false;
    return {};
  }
  std::vector<double> n;
  size_t normal_count = 0;
  OSTEON_RETURN_IF_ERROR(reader.read(normal_accessor, Role::kNormal, &n, &normal_count));
  if (normal_count != *count) {
    return reader.fail("NORMAL has " + std::to_string(normal_count) + " elements, POSITION " +
                           std::to_string(*count),
                       "accessor " + std::to_string(normal_accessor));
  }
  const Mat4& m = world;
  // Row r of the inverse-transpose = cofactor row r / det.
  const double it[9] = {(m[5] * m[10] - m[9] * m[6]) / det, -(m[1] * m[10] - m[9] * m[2]) / det,
                        (m[1] * m[6] - m[5] * m[2]) / det,  -(m[4] * m[10] - m[8] * m[6]) / det,
                        (m[0] * m[10] - m[8] * m[2]) / det, -(m[0] * m[6] - m[4] * m[2]) / det,
                        (m[4] * m[9] - m[8] * m[5]) / det,  -(m[0] * m[9] - m[8] * m[1]) / det,
                        (m[0] * m[5] - m[4] * m[1]) / det};
  for (size_t i = 0; i < *count; ++i) {
    const double* v = &n[3 * i];
    double x = it[0] * v[0] + it[1] * v[1] + it[2] * v[2];
    double y = it[3] * v[0] + it[4] * v[1] + it[5] * v[2];
    double z = it[6] * v[0] + it[7] * v[1] + it[8] * v[2];
    double length = std::sqrt(x * x + y * y + z * z);
    if (!std::isfinite(length)) {
      part->normals_complete = false;
      return {};
    }
    if (length > 0) x /= length, y /= length, z /= length;
    mesh.normals.push_back({static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)});
  }
  return {};
}

/// Appends the triangles of primitive `p` of mesh `mesh_index` to the part.
Status add_primitive(const Reader& reader, const tinygltf::Primitive& prim, int mesh_index,
                     size_t prim_index, const Mat4& world, bool mirrored, const std::string& source,
                     PartBuilder* part) {
  std::string where =
      "mesh " + std::to_string(mesh_index) + " primitive " + std::to_string(prim_index);
  if (prim.mode >= TINYGLTF_MODE_POINTS && prim.mode <= TINYGLTF_MODE_LINE_STRIP) return {};
  if (prim.mode < TINYGLTF_MODE_POINTS || prim.mode > TINYGLTF_MODE_TRIANGLE_FAN) {
    return reader.fail("mode " + std::to_string(prim.mode) + " is not a glTF primitive mode",
                       where);
  }
  auto position = prim.attributes.find("POSITION");
  if (position == prim.attributes.end()) return {};  // the spec: skip it
  auto normal = prim.attributes.find("NORMAL");
  int normal_accessor = normal == prim.attributes.end() ? -1 : normal->second;

  uint32_t base = 0;
  size_t count = 0;
  auto key = std::make_pair(position->second, normal_accessor);
  auto cached = part->blocks.find(key);
  if (cached != part->blocks.end()) {
    base = cached->second.first;
    count = cached->second.second;
  } else {
    OSTEON_RETURN_IF_ERROR(add_vertices(reader, position->second, normal_accessor, world, source,
                                        part, &base, &count));
    part->blocks.emplace(key, std::make_pair(base, count));
  }

  std::vector<double> raw;
  size_t index_count = count;
  if (prim.indices >= 0) {
    OSTEON_RETURN_IF_ERROR(reader.read(prim.indices, Role::kIndices, &raw, &index_count));
    for (size_t i = 0; i < index_count; ++i) {
      if (raw[i] >= static_cast<double>(count)) {
        return reader.fail("index " + std::to_string(i) + " is " +
                               std::to_string(static_cast<uint64_t>(raw[i])) +
                               ", but POSITION has " + std::to_string(count) + " vertices",
                           "accessor " + std::to_string(prim.indices));
      }
    }
  }
  // Strips and fans give at most one triangle per index.
  OSTEON_RETURN_IF_ERROR(charge(part, uint64_t{index_count} * 4, source, where));
  auto at = [&](size_t i) -> uint32_t {
    return base + static_cast<uint32_t>(prim.indices >= 0 ? raw[i] : static_cast<double>(i));
  };
  std::vector<uint32_t>& out = part->mesh.indices;
  auto emit = [&](uint32_t a, uint32_t b, uint32_t c) {
    if (mirrored) std::swap(b, c);
    out.insert(out.end(), {a, b, c});
  };
  if (prim.mode == TINYGLTF_MODE_TRIANGLES) {
    if (index_count % 3 != 0) {
      return reader.fail(
          "TRIANGLES with " + std::to_string(index_count) + " vertices, not a multiple of 3",
          where);
    }
    out.reserve(out.size() + index_count);
    for (size_t i = 0; i < index_count; i += 3) emit(at(i), at(i + 1), at(i + 2));
  } else if (prim.mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
    for (size_t j = 0; j + 2 < index_count; ++j) {
      uint32_t a = at(j), b = at(j + 1), c = at(j + 2);
      if (a == b || b == c || a == c) continue;
      if (j % 2 == 0) {
        emit(a, b, c);
      } else {
        emit(b, a, c);
      }
    }
  } else {  // TRIANGLE_FAN
    for (size_t j = 1; j + 1 < index_count; ++j) emit(at(0), at(j), at(j + 1));
  }
  return {};
}

/// extras.osteon of a node, or null.
const tinygltf::Value* osteon_extras(const tinygltf::Node& node) {
  if (!node.extras.IsObject() || !node.extras.Has("osteon")) return nullptr;
  const tinygltf::Value& o = node.extras.Get("osteon");
  return o.IsObject() ? &o : nullptr;
}

/// A node's part name: extras.osteon.name (osteon export), else the node's name.
std::string part_name(const tinygltf::Node& node) {
  const tinygltf::Value* o = osteon_extras(node);
  if (o != nullptr && o->Has("name") && o->Get("name").IsString()) {
    return o->Get("name").Get<std::string>();
  }
  return node.name;
}

/// Instance i's part name: extras.osteon.instances[i].name (osteon export), else "<node>#<i>".
std::string instance_name(const tinygltf::Node& node, size_t i) {
  const tinygltf::Value* o = osteon_extras(node);
  if (o != nullptr && o->Has("instances") && o->Get("instances").IsArray() &&
      i < o->Get("instances").ArrayLen()) {
    const tinygltf::Value& entry = o->Get("instances").Get(static_cast<int>(i));
    if (entry.IsObject() && entry.Has("name") && entry.Get("name").IsString()) {
      return entry.Get("name").Get<std::string>();
    }
  }
  return node.name + "#" + std::to_string(i);
}

/// The instance matrices of a node's EXT_mesh_gpu_instancing (T * R * S each), or none.
Status instance_matrices(const Reader& reader, const tinygltf::Node& node, int index,
                         const std::string& source, std::vector<Mat4>* out) {
  out->clear();
  auto ext = node.extensions.find("EXT_mesh_gpu_instancing");
  if (ext == node.extensions.end()) return {};
  const std::string where = "node " + std::to_string(index) + " EXT_mesh_gpu_instancing";
  if (!ext->second.IsObject() || !ext->second.Has("attributes") ||
      !ext->second.Get("attributes").IsObject()) {
    return error(ErrorCode::kInvalidData, source, "no attributes object", where);
  }
  const tinygltf::Value& attributes = ext->second.Get("attributes");
  struct Attribute {
    const char* name;
    Role role;
    size_t width;
    std::vector<double> values;
  };
  Attribute list[] = {{"TRANSLATION", Role::kTranslation, 3, {}},
                      {"ROTATION", Role::kRotation, 4, {}},
                      {"SCALE", Role::kScale, 3, {}}};
  size_t count = 0;
  bool any = false;
  for (Attribute& a : list) {
    if (!attributes.Has(a.name)) continue;
    const tinygltf::Value& v = attributes.Get(a.name);
    if (!v.IsInt()) {
      return error(ErrorCode::kInvalidData, source,
                   std::string(a.name) + " is not an accessor index", where);
    }
    size_t n = 0;
    OSTEON_RETURN_IF_ERROR(reader.read(v.Get<int>(), a.role, &a.values, &n));
    if (any && n != count) {
      return error(ErrorCode::kInvalidData, source,
                   std::string(a.name) + " has " + std::to_string(n) + " instances, not " +
                       std::to_string(count),
                   where);
    }
    count = n;
    any = true;
  }
  if (!any) return error(ErrorCode::kInvalidData, source, "no instance attribute", where);
  out->reserve(count);
  for (size_t i = 0; i < count; ++i) {
    tinygltf::Node trs;
    if (!list[0].values.empty()) trs.translation.assign(&list[0].values[3 * i], &list[0].values[3 * i] + 3);
    if (!list[1].values.empty()) trs.rotation.assign(&list[1].values[4 * i], &list[1].values[4 * i] + 4);
    if (!list[2].values.empty()) trs.scale.assign(&list[2].values[3 * i], &list[2].values[3 * i] + 3);
    Mat4 m = kIdentityMatrix;
    OSTEON_RETURN_IF_ERROR(local_matrix(trs, index, source, &m));
    out->push_back(m);
  }
  return {};
}

}  // namespace

Status parse_gltf(const uint8_t* data, size_t size, const std::string& source,
                  const std::string& base_dir, const ReadOptions& options, Scene* scene) {
  const bool glb = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
  GlbLayout layout;
  if (glb) {
    OSTEON_RETURN_IF_ERROR(check_glb(data, size, source, &layout));
  } else {
    if (size > std::numeric_limits<uint32_t>::max()) {  // tinygltf takes a 32-bit length
      return error(ErrorCode::kUnsupported, source, "a .gltf of 4 GiB or more is not supported",
                   "byte 0");
    }
    layout = {size, 0, size};
  }
  size_t deep = too_deep_at(data + layout.json_offset, layout.json_size, kMaxJsonDepth);
  if (deep != std::string_view::npos) {
    return error(ErrorCode::kInvalidData, source,
                 "JSON nested deeper than " + std::to_string(kMaxJsonDepth) + " levels",
                 at_byte(layout.json_offset + deep));
  }

  FilePolicy policy;
  policy.max_bytes = options.max_file_bytes;
  if (!base_dir.empty()) {
    std::error_code ec;
    policy.base = fs::weakly_canonical(fs::path(base_dir), ec);
    if (ec) policy.base.clear();
  }
  // A .gltf with meshopt-compressed views (osteon export writes them beside a .bin): its external
  // buffers embedded, read through the same file policy, so that it is read as the GLB would be.
  std::vector<uint8_t> embedded;
  if (!glb && !policy.base.empty()) {
    auto read_external = [&](const std::string& uri) -> Result<std::vector<uint8_t>> {
      std::vector<unsigned char> bytes;
      std::string err;
      const std::string path = (fs::path(base_dir) / uri).string();
      if (!policy_read(&bytes, &err, path, &policy)) {
        return error(ErrorCode::kIoError, source,
                     "external file '" + uri +
                         "' is missing, not a regular file, outside the glTF's folder or too large");
      }
      return std::vector<uint8_t>(bytes.begin(), bytes.end());
    };
    OSTEON_ASSIGN_OR_RETURN(embedded, embed_gltf_buffers(data, size, source, read_external));
    if (!embedded.empty()) {
      data = embedded.data();
      size = embedded.size();
      OSTEON_RETURN_IF_ERROR(check_glb(data, size, source, &layout));
    }
  }
  const bool is_glb = glb || !embedded.empty();

  // gltfpack's meshopt-compressed views decoded, and required extensions checked, before
  // tinygltf (which refuses a meshopt fallback buffer, and a Draco primitive's accessors, with
  // messages about byte lengths).
  OSTEON_ASSIGN_OR_RETURN(
      std::vector<uint8_t> plain,
      plain_gltf(data + layout.json_offset, layout.json_size, data + layout.bin_offset,
                 layout.bin_size, is_glb, source, &extension_ok));
  if (!plain.empty()) {
    data = plain.data();
    size = plain.size();
    OSTEON_RETURN_IF_ERROR(check_glb(data, size, source, &layout));
  }

  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(&skip_image, nullptr);
  loader.SetFsCallbacks(
      {&policy_file_exists, &policy_expand, &policy_read, &policy_write, &policy});
  tinygltf::Model model;
  std::string err, warn;
  bool loaded = false;
  try {
    if (is_glb) {
      loaded = loader.LoadBinaryFromMemory(&model, &err, &warn, data,
                                           static_cast<unsigned int>(layout.length), base_dir);
    } else {
      loaded = loader.LoadASCIIFromString(&model, &err, &warn, reinterpret_cast<const char*>(data),
                                          static_cast<unsigned int>(size), base_dir);
    }
  } catch (const std::exception& e) {
    loaded = false;
    err = e.what();
  }
  if (!loaded) {
    if (!policy.refused.empty() && err.find("File not found") != std::string::npos) {
      if (policy.base.empty()) {
        return error(ErrorCode::kUnsupported, source,
                     "external file '" + policy.refused +
                         "': a glTF read from memory may only use embedded buffers (data: URIs "
                         "or the GLB BIN chunk)");
      }
      return error(ErrorCode::kIoError, source,
                   "external file '" + policy.refused +
                       "' is missing, not a regular file, or outside the glTF's folder");
    }
    return error(ErrorCode::kInvalidData, source, "invalid glTF: " + one_line(err),
                 at_byte(layout.json_offset));
  }

  const std::string& version = model.asset.version;
  if (version.rfind("2.", 0) != 0 && version != "2") {
    return error(ErrorCode::kUnsupported, source,
                 "glTF version '" + version + "' is not supported (only 2.x)", "asset");
  }
  // Required extensions were checked by plain_gltf, before tinygltf.

  // The root nodes: the default scene's, else scene 0's, else every node nobody points to.
  const size_t node_count = model.nodes.size();
  std::vector<int> roots;
  if (model.defaultScene >= 0) {
    if (static_cast<size_t>(model.defaultScene) >= model.scenes.size()) {
      return error(ErrorCode::kInvalidData, source,
                   "the default scene " + std::to_string(model.defaultScene) + " does not exist",
                   "scene");
    }
    roots = model.scenes[static_cast<size_t>(model.defaultScene)].nodes;
  } else if (!model.scenes.empty()) {
    roots = model.scenes[0].nodes;
  } else {
    std::vector<char> is_child(node_count, 0);
    for (const tinygltf::Node& node : model.nodes) {
      for (int child : node.children) {
        if (child >= 0 && static_cast<size_t>(child) < node_count) is_child[child] = 1;
      }
    }
    for (size_t i = 0; i < node_count; ++i) {
      if (!is_child[i]) roots.push_back(static_cast<int>(i));
    }
  }

  // Depth-first, in document order; every node at most once (the hierarchy must be a tree).
  Reader reader(model, source, size);
  uint64_t emitted = 0;
  const uint64_t budget = kExpansionFloorBytes + kExpansionFactor * uint64_t{size};
  struct Item {
    int node;
    int parent;  // -1: a root
    Mat4 parent_world;
  };
  std::vector<Item> stack;
  for (auto it = roots.rbegin(); it != roots.rend(); ++it) {
    stack.push_back({*it, -1, kIdentityMatrix});
  }
  std::vector<char> visited(node_count, 0);
  while (!stack.empty()) {
    Item item = stack.back();
    stack.pop_back();
    std::string parent_where =
        item.parent < 0 ? std::string("scene") : "node " + std::to_string(item.parent);
    if (item.node < 0 || static_cast<size_t>(item.node) >= node_count) {
      return error(ErrorCode::kInvalidData, source,
                   "node " + std::to_string(item.node) + " does not exist", parent_where);
    }
    if (visited[static_cast<size_t>(item.node)]) {
      return error(ErrorCode::kInvalidData, source,
                   "node " + std::to_string(item.node) +
                       " is reached twice: the node hierarchy must be a tree",
                   parent_where);
    }
    visited[static_cast<size_t>(item.node)] = 1;
    const tinygltf::Node& node = model.nodes[static_cast<size_t>(item.node)];
    std::string where = "node " + std::to_string(item.node);
    Mat4 local = kIdentityMatrix;
    OSTEON_RETURN_IF_ERROR(local_matrix(node, item.node, source, &local));
    Mat4 world = multiply(item.parent_world, local);
    for (auto it = node.children.rbegin(); it != node.children.rend(); ++it) {
      stack.push_back({*it, item.node, world});
    }
    if (node.mesh == -1) continue;
    if (node.mesh < 0 || static_cast<size_t>(node.mesh) >= model.meshes.size()) {
      return error(ErrorCode::kInvalidData, source,
                   "mesh " + std::to_string(node.mesh) + " does not exist", where);
    }
    // One part, or one per EXT_mesh_gpu_instancing instance.
    std::vector<Mat4> instances;
    OSTEON_RETURN_IF_ERROR(instance_matrices(reader, node, item.node, source, &instances));
    const bool instanced = !instances.empty();
    if (!instanced) instances.push_back(kIdentityMatrix);
    const tinygltf::Mesh& mesh = model.meshes[static_cast<size_t>(node.mesh)];
    for (size_t i = 0; i < instances.size(); ++i) {
      PartBuilder part;
      part.mesh.name = instanced ? instance_name(node, i) : part_name(node);
      part.emitted = &emitted;
      part.budget = budget;
      const Mat4 instance_world = instanced ? multiply(world, instances[i]) : world;
      const bool mirrored = determinant3(instance_world) < 0;
      for (size_t p = 0; p < mesh.primitives.size(); ++p) {
        OSTEON_RETURN_IF_ERROR(add_primitive(reader, mesh.primitives[p], node.mesh, p,
                                             instance_world, mirrored, source, &part));
      }
      if (!part.normals_complete || part.mesh.normals.size() != part.mesh.positions.size()) {
        part.mesh.normals.clear();
      }
      if (part.mesh.indices.empty()) continue;  // points or lines only: not a surface
      scene->parts.push_back(std::move(part.mesh));
    }
  }
  return {};
}

}  // namespace osteon::detail
