// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>
#include <string_view>

#include "osteon/io.hpp"
#include "osteon/mesh.hpp"
#include "osteon/status.hpp"

// What the per-format readers (src/io_<format>.cpp) share with the dispatcher in src/io.cpp.
//
// Contract of every `parse_<format>` function:
// - `data`/`size` are the whole file, hostile. `source` is the path used in messages.
// - On success it appends one or more meshes to `scene->parts`. Each mesh gets:
//     name            the sub-part name the file gives (OBJ group, glTF node name), or empty;
//                     the dispatcher turns it into the final part name (file stem, "stem/name");
//     positions, indices (triangles only: polygons fan-triangulated, strips unrolled),
//     normals         only where the file has per-vertex normals that map 1:1 to positions;
//     stored_vertices the number of vertices the file stores for this part.
// - Meshes may be welded or not: the dispatcher welds afterwards when ReadOptions::weld is set
//   (STL welds while streaming, because its soup is 3x the welded size).
// - Every error is `error(ErrorCode::kInvalidData, source, what, where)` with where = "byte N"
//   (binary) or "line N" (text); nothing is allocated from a count before checking that the bytes
//   remaining can hold it; coordinates must be finite; indices must be in range.

namespace osteon::detail {

/// Sets every part's unit: options.unit when given (UnitSource::kUser), else guess_unit's.
void assign_unit(const ReadOptions& options, Scene* scene);

Status parse_stl(const uint8_t* data, size_t size, const std::string& source,
                 const ReadOptions& options, Scene* scene);
/// Binary STL streamed from an open file in ~1 MiB chunks and welded as it arrives, so memory
/// stays near the size of the welded mesh; ASCII STL is read whole and handed to parse_stl.
Status parse_stl_file(std::FILE* file, uint64_t size, const std::string& source,
                      const ReadOptions& options, Scene* scene);
Status parse_obj(const uint8_t* data, size_t size, const std::string& source,
                 const ReadOptions& options, Scene* scene);
Status parse_ply(const uint8_t* data, size_t size, const std::string& source,
                 const ReadOptions& options, Scene* scene);
Status parse_off(const uint8_t* data, size_t size, const std::string& source,
                 const ReadOptions& options, Scene* scene);
Status parse_vtk(const uint8_t* data, size_t size, const std::string& source,
                 const ReadOptions& options, Scene* scene);
/// glTF (JSON) and GLB. `base_dir` is where external buffers of a .gltf are looked up; empty when
/// reading from memory, in which case only embedded (data: URI / GLB) buffers are accepted.
Status parse_gltf(const uint8_t* data, size_t size, const std::string& source,
                  const std::string& base_dir, const ReadOptions& options, Scene* scene);

/// The glTF that web pipelines write, made plain (src/io_gltf_compressed.cpp): when a GLB's
/// buffer views use EXT_meshopt_compression or KHR_meshopt_compression, the same GLB with them
/// and KHR_draco_mesh_compression primitives decoded (meshoptimizer, libdraco) into its BIN chunk
/// and the extensions removed; an empty vector when nothing needs decoding. The glTF reader's one
/// check of required extensions: one for which `readable(name)` is false (and that is not decoded
/// here) is refused: kUnsupported, "requires NAME, which osteon does not read".
/// Errors name `source` and the bufferView: ranges outside the BIN chunk, strides or modes the
/// decoders do not take, data that does not decode, more decoded bytes than the cap.
Result<std::vector<uint8_t>> plain_gltf(const uint8_t* json_text, size_t json_size,
                                        const uint8_t* bin, size_t bin_size, bool glb,
                                        const std::string& source,
                                        bool (*readable)(const std::string&));

/// A .gltf whose buffer views are meshopt-compressed, as a GLB that plain_gltf decodes: every
/// buffer with a relative `uri` (read through `read_external`, which enforces the reader's file
/// policy) concatenated into the BIN chunk, the views (and their meshopt extensions) pointed into
/// it, buffers without a uri (meshopt fallbacks) kept after it. An empty vector when the .gltf
/// names no meshopt compression (it is read as it is). Errors: kUnsupported for a data: URI
/// buffer beside compressed views; read_external's; kInvalidData for a view naming a missing
/// buffer.
Result<std::vector<uint8_t>> embed_gltf_buffers(
    const uint8_t* json_text, size_t json_size, const std::string& source,
    const std::function<Result<std::vector<uint8_t>>(const std::string& uri)>& read_external);

/// Guesses the format from the first bytes (magic numbers and keywords); kUnknown if none fits.
Format sniff_format(const uint8_t* data, size_t size);

/// Parses a whole token as a float. Accepts what strtof accepts for finite numbers plus a leading
/// '+'; "nan"/"inf" parse (so the caller can report them as non-finite rather than as garbage).
inline bool parse_float(std::string_view token, float* out) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), *out);
  if (ec == std::errc::result_out_of_range) {
    // from_chars leaves *out untouched on overflow/underflow: decide by the sign and magnitude.
    double d = std::strtod(std::string(token).c_str(), nullptr);
    *out = static_cast<float>(d);
    return true;
  }
  return ec == std::errc() && ptr == token.data() + token.size();
}

/// Parses a whole token as a signed 64-bit integer (a leading '+' is allowed).
inline bool parse_int(std::string_view token, int64_t* out) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), *out);
  return ec == std::errc() && ptr == token.data() + token.size();
}

inline bool is_finite(const Vec3& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}

/// The error every reader gives for a NaN or infinite coordinate.
inline Status non_finite_error(const std::string& source, size_t vertex, const std::string& where) {
  return error(ErrorCode::kInvalidData, source,
               "vertex " + std::to_string(vertex) + " has a NaN or infinite coordinate", where);
}

/// Appends the fan triangulation (v0, vi, vi+1) of a polygon with `count` >= 3 corners.
inline void add_polygon_fan(Mesh& mesh, const uint32_t* corners, size_t count) {
  for (size_t i = 1; i + 1 < count; ++i) {
    mesh.indices.push_back(corners[0]);
    mesh.indices.push_back(corners[i]);
    mesh.indices.push_back(corners[i + 1]);
  }
}

}  // namespace osteon::detail
