// SPDX-License-Identifier: Apache-2.0
// The glTF that web pipelines write, made plain before the glTF reader sees it: gltfpack's
// EXT_meshopt_compression and KHR_meshopt_compression buffer views are decoded with Debian's
// meshoptimizer (its decoders and filters), KHR_draco_mesh_compression primitives (gltf-transform
// draco, Blender's exporter) with Debian's libdraco, and a required extension osteon cannot
// decode is refused by name before tinygltf fails on the data it cannot see.
//
// Based on: the EXT_meshopt_compression and KHR_meshopt_compression specifications (Khronos glTF
// registry), and KHR_draco_mesh_compression's (a primitive names the bufferView of its Draco
// stream and the Draco attribute id of each glTF attribute; its accessors keep count and type but
// may lose their bufferView): a compressed bufferView names its source buffer, range, element stride, count, mode
// (ATTRIBUTES, TRIANGLES, INDICES) and filter (NONE, OCTAHEDRAL, QUATERNION, EXPONENTIAL); the
// file's own `buffer` of such a view is a fallback that may hold no data (in a GLB, a buffer with
// a byteLength and no bytes, which is what tinygltf refuses).
//
// How: the JSON (checked for depth before) is parsed with nlohmann::json; each compressed view is
// decoded into a new BIN chunk after the original bytes, the view pointed at it, the extension
// removed; the fallback buffers go; a GLB is written back and read as any other. Everything the
// file declares is checked against what it holds first (ranges inside the BIN chunk, strides the
// decoders take), and the decoded bytes are capped at kMaxExpansion times the compressed ones
// plus a floor, so a small file cannot ask for terabytes.

#include <draco/compression/decode.h>
#include <meshoptimizer.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "io_internal.hpp"

namespace osteon::detail {

namespace {

using json = nlohmann::json;

constexpr const char* kMeshoptNames[] = {"EXT_meshopt_compression", "KHR_meshopt_compression"};
/// Decoded bytes allowed per compressed byte (meshopt's codecs reach 10-30x on real data; a
/// buffer of zeros, more), plus a floor.
constexpr uint64_t kMaxExpansion = 256;
constexpr uint64_t kExpansionFloor = uint64_t{64} << 20;

std::string view_at(size_t k) { return "bufferViews[" + std::to_string(k) + "]"; }

/// A non-negative integer member, or `fallback` when absent; false for anything else.
bool count_member(const json& object, const char* key, uint64_t fallback, uint64_t* out) {
  const auto it = object.find(key);
  if (it == object.end()) {
    *out = fallback;
    return true;
  }
  if (!it->is_number_unsigned()) return false;
  *out = it->get<uint64_t>();
  return true;
}

bool is_meshopt(const std::string& name) {
  return name == kMeshoptNames[0] || name == kMeshoptNames[1];
}

/// The one meshopt extension object of a view or buffer, or null.
const json* meshopt_of(const json& object) {
  const auto ext = object.find("extensions");
  if (ext == object.end() || !ext->is_object()) return nullptr;
  for (const char* name : kMeshoptNames) {
    const auto it = ext->find(name);
    if (it != ext->end() && it->is_object()) return &*it;
  }
  return nullptr;
}

void erase_meshopt(json& object) {
  json& ext = object["extensions"];
  for (const char* name : kMeshoptNames) ext.erase(name);
  if (ext.empty()) object.erase("extensions");
}

/// Bytes [offset, offset + length) inside the BIN chunk of `bin_size` bytes, else an error at
/// `where` (`what`: "compressed bytes", "bytes").
Status check_in_bin(uint64_t offset, uint64_t length, size_t bin_size, const char* what,
                    const std::string& source, const std::string& where) {
  if (offset <= bin_size && length <= bin_size - offset) return {};
  return error(ErrorCode::kInvalidData, source,
               std::string(what) + " " + std::to_string(offset) + "-" +
                   std::to_string(offset + length) + " lie beyond the BIN chunk's " +
                   std::to_string(bin_size),
               where);
}

/// Appends `bytes` to the BIN chunk at a 4-byte boundary; returns where they start.
size_t append_aligned(std::vector<uint8_t>* out_bin, const std::vector<uint8_t>& bytes) {
  while (out_bin->size() % 4 != 0) out_bin->push_back(0);
  const size_t at = out_bin->size();
  out_bin->insert(out_bin->end(), bytes.begin(), bytes.end());
  return at;
}

/// Decodes one compressed view's data into `out` (count * stride bytes).
Status decode_view(const json& m, size_t k, const uint8_t* bin, size_t bin_size,
                   const std::string& source, uint64_t* budget, std::vector<uint8_t>* out) {
  const std::string where = view_at(k);
  uint64_t buffer = 0, offset = 0, length = 0, stride = 0, count = 0;
  if (!count_member(m, "buffer", UINT64_MAX, &buffer) ||
      !count_member(m, "byteOffset", 0, &offset) ||
      !count_member(m, "byteLength", UINT64_MAX, &length) ||
      !count_member(m, "byteStride", UINT64_MAX, &stride) ||
      !count_member(m, "count", UINT64_MAX, &count) || buffer == UINT64_MAX ||
      length == UINT64_MAX || stride == UINT64_MAX || count == UINT64_MAX) {
    return error(ErrorCode::kInvalidData, source,
                 "the meshopt extension needs buffer, byteLength, byteStride and count as counts",
                 where);
  }
  if (buffer != 0) {
    return error(ErrorCode::kUnsupported, source,
                 "meshopt data outside the GLB's BIN chunk (buffer " + std::to_string(buffer) +
                     ") is not read",
                 where);
  }
  OSTEON_RETURN_IF_ERROR(check_in_bin(offset, length, bin_size, "compressed bytes", source, where));
  const std::string mode = m.value("mode", std::string());
  const std::string filter = m.value("filter", std::string("NONE"));
  const bool attributes = mode == "ATTRIBUTES";
  if (!attributes && mode != "TRIANGLES" && mode != "INDICES") {
    return error(ErrorCode::kInvalidData, source, "unknown meshopt mode '" + mode + "'", where);
  }
  if (attributes ? (stride == 0 || stride > 256 || stride % 4 != 0) : (stride != 2 && stride != 4)) {
    return error(ErrorCode::kInvalidData, source,
                 "byteStride " + std::to_string(stride) + " is not allowed for mode " + mode, where);
  }
  if (mode == "TRIANGLES" && count % 3 != 0) {
    return error(ErrorCode::kInvalidData, source,
                 "a TRIANGLES view of " + std::to_string(count) + " indices", where);
  }
  if (count > (uint64_t{1} << 32) || count * stride > *budget) {
    return error(ErrorCode::kInvalidData, source,
                 "declares " + std::to_string(count) + " elements of " + std::to_string(stride) +
                     " bytes, more than its " + std::to_string(length) +
                     " compressed bytes can hold",
                 where);
  }
  *budget -= count * stride;
  out->assign(size_t(count * stride), 0);
  const uint8_t* src = bin + offset;
  int rc = -1;
  if (attributes) {
    // meshoptimizer 0.18 decodes the vertex codec's version 0 (EXT_meshopt_compression's);
    // KHR_meshopt_compression also allows version 1 (meshoptimizer 0.23 and later).
    if (length > 0 && (src[0] & 0xf0) == 0xa0 && (src[0] & 0x0f) != 0) {
      return error(ErrorCode::kUnsupported, source,
                   "meshopt vertex codec version " + std::to_string(src[0] & 0x0f) +
                       " is not read (Debian's meshoptimizer 0.18 decodes version 0; gltfpack "
                       "-cc writes it)",
                   where);
    }
    rc = meshopt_decodeVertexBuffer(out->data(), size_t(count), size_t(stride), src, size_t(length));
  } else if (mode == "TRIANGLES") {
    rc = meshopt_decodeIndexBuffer(out->data(), size_t(count), size_t(stride), src, size_t(length));
  } else {
    rc = meshopt_decodeIndexSequence(out->data(), size_t(count), size_t(stride), src,
                                     size_t(length));
  }
  if (rc != 0) {
    return error(ErrorCode::kInvalidData, source,
                 "meshopt " + mode + " data does not decode (error " + std::to_string(rc) + ")",
                 where);
  }
  if (filter == "NONE") return {};
  if (!attributes) {
    return error(ErrorCode::kInvalidData, source, "a filter on " + mode + " data", where);
  }
  if (filter == "OCTAHEDRAL" && (stride == 4 || stride == 8)) {
    meshopt_decodeFilterOct(out->data(), size_t(count), size_t(stride));
  } else if (filter == "QUATERNION" && stride == 8) {
    meshopt_decodeFilterQuat(out->data(), size_t(count), size_t(stride));
  } else if (filter == "EXPONENTIAL") {
    meshopt_decodeFilterExp(out->data(), size_t(count), size_t(stride));
  } else {
    return error(ErrorCode::kUnsupported, source,
                 "meshopt filter '" + filter + "' on " + std::to_string(stride) +
                     "-byte elements is not read",
                 where);
  }
  return {};
}

constexpr const char* kDraco = "KHR_draco_mesh_compression";

/// The Draco extension object of a primitive, or null.
const json* draco_of(const json& primitive) {
  const auto ext = primitive.find("extensions");
  if (ext == primitive.end() || !ext->is_object()) return nullptr;
  const auto it = ext->find(kDraco);
  return it != ext->end() && it->is_object() ? &*it : nullptr;
}

/// The bytes of bufferView `k` inside the BIN chunk (uncompressed views only).
Status view_bytes(const json& doc, uint64_t k, const uint8_t* bin, size_t bin_size,
                  const std::string& source, const std::string& where, const uint8_t** out,
                  size_t* size) {
  // find, not operator[]: on a const document, [] of an absent key reads freed memory.
  const auto views_it = doc.find("bufferViews");
  if (views_it == doc.end() || !views_it->is_array() || k >= views_it->size() ||
      !(*views_it)[k].is_object()) {
    return error(ErrorCode::kInvalidData, source, "no bufferView " + std::to_string(k), where);
  }
  const json& views = *views_it;
  uint64_t buffer = 0, offset = 0, length = 0;
  if (!count_member(views[k], "buffer", UINT64_MAX, &buffer) ||
      !count_member(views[k], "byteOffset", 0, &offset) ||
      !count_member(views[k], "byteLength", UINT64_MAX, &length) || length == UINT64_MAX) {
    return error(ErrorCode::kInvalidData, source, "bad buffer, byteOffset or byteLength",
                 view_at(k));
  }
  if (buffer != 0) {
    return error(ErrorCode::kUnsupported, source,
                 "Draco data outside the GLB's BIN chunk is not read", view_at(k));
  }
  OSTEON_RETURN_IF_ERROR(check_in_bin(offset, length, bin_size, "bytes", source, view_at(k)));
  *out = bin + offset;
  *size = size_t(length);
  return {};
}

/// Appends `bytes` to the BIN chunk as a new view; returns its index.
size_t append_view(json& doc, std::vector<uint8_t>* out_bin, const std::vector<uint8_t>& bytes) {
  const size_t at = append_aligned(out_bin, bytes);
  doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", at}, {"byteLength", bytes.size()}});
  return doc["bufferViews"].size() - 1;
}

/// Points accessor `a` at a new view of `bytes` (`component` type, `count` elements).
Status rewrite_accessor(json& doc, const json& index, int component, size_t count,
                        const std::string& source, const std::string& where,
                        std::vector<uint8_t>* out_bin, const std::vector<uint8_t>& bytes) {
  json& accessors = doc["accessors"];
  if (!index.is_number_unsigned() || !accessors.is_array() ||
      index.get<uint64_t>() >= accessors.size() || !accessors[index.get<size_t>()].is_object()) {
    return error(ErrorCode::kInvalidData, source, "names no accessor", where);
  }
  json& a = accessors[index.get<size_t>()];
  a["bufferView"] = append_view(doc, out_bin, bytes);
  a["byteOffset"] = 0;
  a["componentType"] = component;
  a["count"] = count;
  a.erase("normalized");
  a.erase("sparse");
  return {};
}

/// Decodes the Draco stream of mesh `m`'s primitive `p` and points its POSITION and indices
/// accessors at the decoded data; its other attributes are dropped (osteon reads geometry).
Status decode_draco(json& doc, json& primitive, size_t m, size_t p, const uint8_t* bin,
                    size_t bin_size, const std::string& source, uint64_t* budget,
                    std::vector<uint8_t>* out_bin) {
  const std::string where =
      "meshes[" + std::to_string(m) + "].primitives[" + std::to_string(p) + "]";
  const json ext = *draco_of(primitive);
  uint64_t view = 0, position_id = 0;
  if (!count_member(ext, "bufferView", UINT64_MAX, &view) || view == UINT64_MAX ||
      !ext.contains("attributes") || !ext["attributes"].is_object() ||
      !count_member(ext["attributes"], "POSITION", UINT64_MAX, &position_id) ||
      position_id == UINT64_MAX) {
    return error(ErrorCode::kInvalidData, source,
                 "KHR_draco_mesh_compression needs a bufferView and a POSITION attribute id",
                 where);
  }
  const uint8_t* bytes = nullptr;
  size_t size = 0;
  OSTEON_RETURN_IF_ERROR(view_bytes(doc, view, bin, bin_size, source, where, &bytes, &size));
  draco::DecoderBuffer buffer;
  buffer.Init(reinterpret_cast<const char*>(bytes), size);
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok()) {
    return error(ErrorCode::kInvalidData, source,
                 "the Draco stream does not decode: " + decoded.status().error_msg_string(),
                 where);
  }
  const draco::Mesh& mesh = *decoded.value();
  const draco::PointAttribute* positions =
      mesh.GetAttributeByUniqueId(static_cast<uint32_t>(position_id));
  if (positions == nullptr || positions->num_components() != 3) {
    return error(ErrorCode::kInvalidData, source,
                 "the Draco stream has no 3-component attribute " + std::to_string(position_id),
                 where);
  }
  const uint64_t points = mesh.num_points(), faces = mesh.num_faces();
  if (12 * points + 12 * faces > *budget) {
    return error(ErrorCode::kInvalidData, source,
                 "decodes to more than its " + std::to_string(size) + " bytes can hold", where);
  }
  *budget -= 12 * points + 12 * faces;
  std::vector<uint8_t> xyz(size_t(12 * points));
  for (uint32_t i = 0; i < points; ++i) {
    float v[3] = {0, 0, 0};
    if (!positions->ConvertValue<float, 3>(positions->mapped_index(draco::PointIndex(i)), v)) {
      return error(ErrorCode::kInvalidData, source, "a Draco position does not convert", where);
    }
    std::memcpy(xyz.data() + 12 * size_t(i), v, 12);
  }
  std::vector<uint8_t> ids(size_t(12 * faces));
  for (uint32_t f = 0; f < faces; ++f) {
    const draco::Mesh::Face& face = mesh.face(draco::FaceIndex(f));
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = face[k].value();
      std::memcpy(ids.data() + 12 * size_t(f) + 4 * size_t(k), &v, 4);
    }
  }
  json& attributes = primitive["attributes"];
  if (!attributes.is_object() || !attributes.contains("POSITION")) {
    return error(ErrorCode::kInvalidData, source, "a Draco primitive without POSITION", where);
  }
  OSTEON_RETURN_IF_ERROR(rewrite_accessor(doc, attributes["POSITION"], 5126, size_t(points),
                                          source, where + ".attributes.POSITION", out_bin, xyz));
  if (primitive.contains("indices")) {
    OSTEON_RETURN_IF_ERROR(rewrite_accessor(doc, primitive["indices"], 5125, size_t(3 * faces),
                                            source, where + ".indices", out_bin, ids));
  } else {
    doc["accessors"].push_back({{"componentType", 5125}, {"count", 3 * faces}, {"type", "SCALAR"},
                                {"bufferView", append_view(doc, out_bin, ids)}});
    primitive["indices"] = doc["accessors"].size() - 1;
  }
  attributes = json{{"POSITION", attributes["POSITION"]}};
  primitive["extensions"].erase(kDraco);
  if (primitive["extensions"].empty()) primitive.erase("extensions");
  return {};
}

void put_le32(std::vector<uint8_t>* out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out->push_back(uint8_t(v >> (8 * i)));
}

}  // namespace

Result<std::vector<uint8_t>> plain_gltf(const uint8_t* json_text, size_t json_size,
                                        const uint8_t* bin, size_t bin_size, bool glb,
                                        const std::string& source,
                                        bool (*readable)(const std::string&)) {
  // Most glTF needs nothing here: the JSON is parsed a second time (tinygltf parses it next) only
  // when it names a required extension or a compression.
  const std::string_view original(reinterpret_cast<const char*>(json_text), json_size);
  if (original.find("extensionsRequired") == std::string_view::npos &&
      original.find("_meshopt_compression") == std::string_view::npos &&
      original.find(kDraco) == std::string_view::npos) {
    return std::vector<uint8_t>();
  }
  json doc = json::parse(json_text, json_text + json_size, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) return std::vector<uint8_t>();  // tinygltf says why
  bool meshopt = false;
  const auto views = doc.find("bufferViews");
  if (glb && views != doc.end() && views->is_array()) {
    for (const json& view : *views) meshopt = meshopt || meshopt_of(view) != nullptr;
  }
  bool draco = false;
  const auto meshes = doc.find("meshes");
  if (glb && meshes != doc.end() && meshes->is_array()) {
    for (const json& mesh : *meshes) {
      if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array()) {
        continue;
      }
      for (const json& primitive : mesh["primitives"]) {
        draco = draco || (primitive.is_object() && draco_of(primitive) != nullptr);
      }
    }
  }
  // The one check of required extensions: those decoded below pass, the others must be readable.
  if (const auto required = doc.find("extensionsRequired");
      required != doc.end() && required->is_array()) {
    for (const json& name : *required) {
      if (!name.is_string()) continue;
      const std::string n = name.get<std::string>();
      if ((meshopt && is_meshopt(n)) || (draco && n == kDraco)) continue;
      if (!readable(n)) {
        return error(ErrorCode::kUnsupported, source,
                     "requires " + n + ", which osteon does not read" +
                         (!glb && (is_meshopt(n) || n == kDraco)
                              ? " in a .gltf (convert it to .glb)"
                              : ""),
                     "extensionsRequired");
      }
    }
  }
  if (!meshopt && !draco) return std::vector<uint8_t>();

  // Every compressed view decoded after the original BIN bytes.
  std::vector<uint8_t> out_bin(bin, bin + bin_size);
  uint64_t budget = kExpansionFloor + kMaxExpansion * uint64_t(bin_size);
  std::vector<uint8_t> decoded;
  for (size_t k = 0; meshopt && k < views->size(); ++k) {
    json& view = (*views)[k];
    const json* m = meshopt_of(view);
    if (m == nullptr) continue;
    OSTEON_RETURN_IF_ERROR(decode_view(*m, k, bin, bin_size, source, &budget, &decoded));
    view["buffer"] = 0;
    view["byteOffset"] = append_aligned(&out_bin, decoded);
    view["byteLength"] = decoded.size();
    erase_meshopt(view);
  }
  for (size_t m = 0; draco && m < meshes->size(); ++m) {
    json& mesh = (*meshes)[m];
    if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array()) {
      continue;
    }
    for (size_t p = 0; p < mesh["primitives"].size(); ++p) {
      json& primitive = mesh["primitives"][p];
      if (!primitive.is_object() || draco_of(primitive) == nullptr) continue;
      OSTEON_RETURN_IF_ERROR(
          decode_draco(doc, primitive, m, p, bin, bin_size, source, &budget, &out_bin));
    }
  }
  // The fallback buffers go; every view now reads the BIN chunk (buffer 0).
  for (size_t k = 0; meshopt && k < views->size(); ++k) {
    if ((*views)[k].value("buffer", -1) != 0) {
      return error(ErrorCode::kUnsupported, source,
                   "a meshopt-compressed GLB whose uncompressed views use other buffers than the "
                   "BIN chunk",
                   view_at(k));
    }
  }
  while (out_bin.size() % 4 != 0) out_bin.push_back(0);
  if (meshopt) {
    doc["buffers"] = json::array({json{{"byteLength", out_bin.size()}}});
  } else {
    doc["buffers"][0]["byteLength"] = out_bin.size();
  }
  for (const char* key : {"extensionsUsed", "extensionsRequired"}) {
    auto it = doc.find(key);
    if (it == doc.end() || !it->is_array()) continue;
    json kept = json::array();
    for (const json& name : *it) {
      const bool done = name.is_string() && ((meshopt && is_meshopt(name.get<std::string>())) ||
                                                (draco && name.get<std::string>() == kDraco));
      if (!done) kept.push_back(name);
    }
    if (kept.empty()) {
      doc.erase(key);
    } else {
      *it = std::move(kept);
    }
  }

  std::string text = doc.dump();
  while (text.size() % 4 != 0) text.push_back(' ');
  if (12 + 8 + text.size() + 8 + out_bin.size() > UINT32_MAX) {
    return error(ErrorCode::kUnsupported, source, "decoded, the GLB would pass 4 GiB");
  }
  std::vector<uint8_t> glb_out;
  glb_out.reserve(28 + text.size() + out_bin.size());
  put_le32(&glb_out, 0x46546C67);
  put_le32(&glb_out, 2);
  put_le32(&glb_out, uint32_t(28 + text.size() + out_bin.size()));
  put_le32(&glb_out, uint32_t(text.size()));
  put_le32(&glb_out, 0x4E4F534A);
  glb_out.insert(glb_out.end(), text.begin(), text.end());
  put_le32(&glb_out, uint32_t(out_bin.size()));
  put_le32(&glb_out, 0x004E4942);
  glb_out.insert(glb_out.end(), out_bin.begin(), out_bin.end());
  return glb_out;
}

Result<std::vector<uint8_t>> embed_gltf_buffers(
    const uint8_t* json_text, size_t json_size, const std::string& source,
    const std::function<Result<std::vector<uint8_t>>(const std::string& uri)>& read_external) {
  const std::string_view original(reinterpret_cast<const char*>(json_text), json_size);
  if (original.find("_meshopt_compression") == std::string_view::npos) {
    return std::vector<uint8_t>();
  }
  json doc = json::parse(json_text, json_text + json_size, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) return std::vector<uint8_t>();  // tinygltf says why
  const auto buffers = doc.find("buffers");
  if (buffers == doc.end() || !buffers->is_array()) return std::vector<uint8_t>();
  // Buffer k -> (new index, offset in the BIN chunk): files first, into buffer 0.
  std::vector<uint8_t> bin;
  std::vector<std::pair<int64_t, uint64_t>> moved(buffers->size(), {-1, 0});
  json kept = json::array({json::object()});
  for (size_t k = 0; k < buffers->size(); ++k) {
    const json& buffer = (*buffers)[k];
    const std::string where = "buffers[" + std::to_string(k) + "]";
    if (!buffer.is_object()) {
      return error(ErrorCode::kInvalidData, source, "not an object", where);
    }
    const auto uri = buffer.find("uri");
    if (uri == buffer.end()) {
      moved[k] = {int64_t(kept.size()), 0};
      kept.push_back(buffer);
      continue;
    }
    if (!uri->is_string()) return error(ErrorCode::kInvalidData, source, "uri is not a string", where);
    const std::string name = uri->get<std::string>();
    if (name.rfind("data:", 0) == 0) {
      return error(ErrorCode::kUnsupported, source,
                   "a data: URI buffer beside meshopt-compressed views (use a .bin or a .glb)",
                   where);
    }
    OSTEON_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, read_external(name));
    uint64_t declared = 0;
    if (!count_member(buffer, "byteLength", 0, &declared) || declared > bytes.size()) {
      return error(ErrorCode::kInvalidData, source,
                   "byteLength is not a count of at most the file's " +
                       std::to_string(bytes.size()) + " bytes",
                   where);
    }
    while (bin.size() % 4 != 0) bin.push_back(0);
    moved[k] = {0, bin.size()};
    bin.insert(bin.end(), bytes.begin(), bytes.begin() + int64_t(declared));
  }
  while (bin.size() % 4 != 0) bin.push_back(0);
  if (bin.size() > UINT32_MAX) {
    return error(ErrorCode::kUnsupported, source, "external buffers of 4 GiB or more");
  }
  kept[0] = {{"byteLength", bin.size()}};
  auto remap = [&](json& object, const std::string& where) -> Status {
    uint64_t index = 0, offset = 0;
    if (!count_member(object, "buffer", UINT64_MAX, &index) || index >= moved.size() ||
        !count_member(object, "byteOffset", 0, &offset)) {
      return error(ErrorCode::kInvalidData, source, "names no valid buffer and byteOffset", where);
    }
    object["buffer"] = moved[index].first;
    object["byteOffset"] = offset + moved[index].second;
    return {};
  };
  if (const auto views = doc.find("bufferViews"); views != doc.end() && views->is_array()) {
    for (size_t k = 0; k < views->size(); ++k) {
      json& view = (*views)[k];
      if (!view.is_object()) continue;  // tinygltf says why
      OSTEON_RETURN_IF_ERROR(remap(view, view_at(k)));
      if (const json* m = meshopt_of(view); m != nullptr) {
        for (const char* name : kMeshoptNames) {
          auto ext = view["extensions"].find(name);
          if (ext != view["extensions"].end() && ext->is_object()) {
            OSTEON_RETURN_IF_ERROR(remap(*ext, view_at(k) + " " + name));
          }
        }
      }
    }
  }
  doc["buffers"] = std::move(kept);
  std::string text = doc.dump(-1, ' ', false, json::error_handler_t::replace);
  while (text.size() % 4 != 0) text.push_back(' ');
  std::vector<uint8_t> glb_out;
  glb_out.reserve(28 + text.size() + bin.size());
  put_le32(&glb_out, 0x46546C67);
  put_le32(&glb_out, 2);
  put_le32(&glb_out, uint32_t(28 + text.size() + bin.size()));
  put_le32(&glb_out, uint32_t(text.size()));
  put_le32(&glb_out, 0x4E4F534A);
  glb_out.insert(glb_out.end(), text.begin(), text.end());
  put_le32(&glb_out, uint32_t(bin.size()));
  put_le32(&glb_out, 0x004E4942);
  glb_out.insert(glb_out.end(), bin.begin(), bin.end());
  return glb_out;
}

}  // namespace osteon::detail
