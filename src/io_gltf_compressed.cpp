// SPDX-License-Identifier: Apache-2.0
// The glTF that web pipelines write, made plain before the glTF reader sees it: gltfpack's
// EXT_meshopt_compression and KHR_meshopt_compression buffer views are decoded with Debian's
// meshoptimizer (its decoders and filters), and a required extension osteon cannot decode is
// refused by name before tinygltf fails on the data it cannot see.
//
// Based on: the EXT_meshopt_compression and KHR_meshopt_compression specifications (Khronos glTF
// registry): a compressed bufferView names its source buffer, range, element stride, count, mode
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

#include <meshoptimizer.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <nlohmann/json.hpp>
#include <string>
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
  if (offset > bin_size || length > bin_size - offset) {
    return error(ErrorCode::kInvalidData, source,
                 "compressed bytes " + std::to_string(offset) + "-" + std::to_string(offset + length) +
                     " lie beyond the BIN chunk's " + std::to_string(bin_size),
                 where);
  }
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

void put_le32(std::vector<uint8_t>* out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out->push_back(uint8_t(v >> (8 * i)));
}

}  // namespace

Result<std::vector<uint8_t>> plain_gltf(const uint8_t* json_text, size_t json_size,
                                        const uint8_t* bin, size_t bin_size, bool glb,
                                        const std::string& source,
                                        bool (*readable)(const std::string&)) {
  json doc = json::parse(json_text, json_text + json_size, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) return std::vector<uint8_t>();  // tinygltf says why
  bool meshopt = false;
  if (const auto required = doc.find("extensionsRequired");
      required != doc.end() && required->is_array()) {
    for (const json& name : *required) {
      if (!name.is_string()) continue;
      const std::string n = name.get<std::string>();
      if (is_meshopt(n) && glb) continue;
      if (!readable(n)) {
        return error(ErrorCode::kUnsupported, source,
                     "requires " + n + ", which osteon does not read" +
                         (is_meshopt(n) ? " in a .gltf (convert it to .glb)" : ""),
                     "extensionsRequired");
      }
    }
  }
  const auto views = doc.find("bufferViews");
  if (glb && views != doc.end() && views->is_array()) {
    for (const json& view : *views) meshopt = meshopt || meshopt_of(view) != nullptr;
  }
  if (!meshopt) return std::vector<uint8_t>();

  // Every compressed view decoded after the original BIN bytes.
  std::vector<uint8_t> out_bin(bin, bin + bin_size);
  uint64_t budget = kExpansionFloor + kMaxExpansion * uint64_t(bin_size);
  std::vector<uint8_t> decoded;
  for (size_t k = 0; k < views->size(); ++k) {
    json& view = (*views)[k];
    const json* m = meshopt_of(view);
    if (m == nullptr) continue;
    OSTEON_RETURN_IF_ERROR(decode_view(*m, k, bin, bin_size, source, &budget, &decoded));
    while (out_bin.size() % 4 != 0) out_bin.push_back(0);
    view["buffer"] = 0;
    view["byteOffset"] = out_bin.size();
    view["byteLength"] = decoded.size();
    out_bin.insert(out_bin.end(), decoded.begin(), decoded.end());
    erase_meshopt(view);
  }
  // The fallback buffers go; every view now reads the BIN chunk (buffer 0).
  for (size_t k = 0; k < views->size(); ++k) {
    if ((*views)[k].value("buffer", -1) != 0) {
      return error(ErrorCode::kUnsupported, source,
                   "a meshopt-compressed GLB whose uncompressed views use other buffers than the "
                   "BIN chunk",
                   view_at(k));
    }
  }
  while (out_bin.size() % 4 != 0) out_bin.push_back(0);
  doc["buffers"] = json::array({json{{"byteLength", out_bin.size()}}});
  for (const char* key : {"extensionsUsed", "extensionsRequired"}) {
    auto it = doc.find(key);
    if (it == doc.end() || !it->is_array()) continue;
    json kept = json::array();
    for (const json& name : *it) {
      if (!(name.is_string() && is_meshopt(name.get<std::string>()))) kept.push_back(name);
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

}  // namespace osteon::detail
