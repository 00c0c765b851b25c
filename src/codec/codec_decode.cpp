// SPDX-License-Identifier: Apache-2.0
#include <cmath>
#include <cstring>

#include "codec/codec_internal.hpp"
#include "codec/connectivity.hpp"
#include "codec/entropy.hpp"
#include "codec/geometry.hpp"
#include "codec/normals.hpp"
#include "core/byte_io.hpp"
#include "osteon/codec.hpp"

// The codec's decoder: checks the container (magic, version, checksum, counts) before anything is
// allocated, then decodes connectivity, geometry, and computes smooth normals. This file, with the
// connectivity and geometry decoders and the entropy coder, is all the WebAssembly build holds.

namespace osteon {

std::vector<Vec3> compute_vertex_normals(const Mesh& mesh) {
  std::vector<Vec3> normals(mesh.positions.size(), Vec3{0, 0, 0});
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    uint32_t a = mesh.indices[3 * t], b = mesh.indices[3 * t + 1], c = mesh.indices[3 * t + 2];
    const Vec3 &p = mesh.positions[a], &q = mesh.positions[b], &r = mesh.positions[c];
    // The cross product's length is twice the area: summing it weights by area.
    const Vec3 n = cross(q - p, r - p);
    for (uint32_t v : {a, b, c}) {
      normals[v].x += n.x;
      normals[v].y += n.y;
      normals[v].z += n.z;
    }
  }
  for (Vec3& n : normals) {
    const float length = std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    const float scale = length > 0 ? 1 / length : 0;  // one division, not three
    n = {n.x * scale, n.y * scale, n.z * scale};
  }
  return normals;
}

namespace {

/// The checks every reader of a stream starts with: its length, magic and version.
Status check_stream_header(const uint8_t* data, size_t size, const std::string& source) {
  if (size < detail::kStreamHeaderBytes + detail::kStreamChecksumBytes) {
    return error(ErrorCode::kInvalidData, source,
                 detail::message("too short for an osteon stream (% bytes, at least %)",
                                 {size, detail::kStreamHeaderBytes + detail::kStreamChecksumBytes}),
                 at_byte(size));
  }
  if (std::memcmp(data, detail::kStreamMagic, 4) != 0) {
    return error(ErrorCode::kInvalidData, source, "not an osteon stream (wrong magic)", "byte 0");
  }
  if (data[4] < detail::kOldestStreamVersion || data[4] > detail::kStreamVersion) {
    return error(ErrorCode::kUnsupported, source,
                 detail::message("stream version % (this decoder reads versions % to %)",
                                 {data[4], detail::kOldestStreamVersion, detail::kStreamVersion}),
                 "byte 4");
  }
  return Status();
}

}  // namespace

Result<Mesh> decode(const uint8_t* data, size_t size, const std::string& source) {
  OSTEON_RETURN_IF_ERROR(check_stream_header(data, size, source));
  uint32_t stored_crc = ByteReader::load<uint32_t>(data + size - 4, std::endian::little);
  if (detail::crc32(data, size - 4) != stored_crc) {
    return error(ErrorCode::kInvalidData, source, "checksum mismatch: the stream is corrupt",
                 at_byte(size - 4));
  }
  ByteReader in(data, size - detail::kStreamChecksumBytes);
  in.skip(5);
  uint8_t flags = 0;
  uint16_t reserved = 0;
  uint32_t vertex_count = 0, triangle_count = 0;
  double origin[3], step = 0;
  uint32_t lengths[3];
  in.read_le(&flags);
  in.read_le(&reserved);
  in.read_le(&vertex_count);
  in.read_le(&triangle_count);
  for (double& o : origin) in.read_le(&o);
  in.read_le(&step);
  for (uint32_t& l : lengths) in.read_le(&l);
  const bool has_normals = (flags & 1) != 0;
  if ((flags & ~1) != 0 || reserved != 0) {
    return error(ErrorCode::kUnsupported, source, "unknown flags in the header", "byte 5");
  }
  if (has_normals != (lengths[2] != 0)) {
    return error(ErrorCode::kInvalidData, source,
                 "the normals flag and the normals section's length disagree", "byte 56");
  }
  if (triangle_count > detail::kMaxTriangles ||
      uint64_t{triangle_count} > detail::kMaxTrianglesPerByte * uint64_t{size} ||
      uint64_t{vertex_count} > 3 * uint64_t{triangle_count}) {
    return error(ErrorCode::kInvalidData, source,
                 detail::message("implausible counts: % vertices, % triangles in % bytes",
                                 {vertex_count, triangle_count, size}),
                 "byte 8");
  }
  if (!(step > 0) || !std::isfinite(step) || !std::isfinite(origin[0]) ||
      !std::isfinite(origin[1]) || !std::isfinite(origin[2])) {
    return error(ErrorCode::kInvalidData, source, "invalid quantization grid", "byte 16");
  }
  if (uint64_t{lengths[0]} + lengths[1] + lengths[2] != in.remaining()) {
    return error(ErrorCode::kInvalidData, source,
                 "section lengths do not add up to the stream's size", "byte 48");
  }
  size_t base = in.offset();
  ByteReader connectivity_in(data + base, lengths[0]);
  OSTEON_ASSIGN_OR_RETURN(
      detail::DecodedConnectivity connectivity,
      detail::decode_connectivity(connectivity_in, vertex_count, triangle_count, source));
  ByteReader geometry_in(data + base + lengths[0], lengths[1]);
  OSTEON_ASSIGN_OR_RETURN(
      detail::QuantizedPositions q,
      detail::decode_geometry(geometry_in, connectivity.newest, vertex_count, data[4], source));
  connectivity.newest = detail::NewestTriangles();  // free it before the normals' arrays
  std::vector<uint32_t>& indices = connectivity.indices;
  QuantizationGrid grid;
  grid.origin = {float(origin[0]), float(origin[1]), float(origin[2])};
  grid.step = step;
  Mesh mesh;
  mesh.positions = detail::dequantize(q, grid);
  mesh.indices = std::move(indices);
  mesh.stored_vertices = vertex_count;
  if (has_normals) {
    ByteReader normals_in(data + base + lengths[0] + lengths[1], lengths[2]);
    OSTEON_ASSIGN_OR_RETURN(mesh.normals,
                            detail::decode_normals(normals_in, mesh.indices, q, source));
  } else {
    mesh.normals = compute_vertex_normals(mesh);
  }
  return mesh;
}

Result<QuantizationGrid> stream_grid(const uint8_t* data, size_t size, const std::string& source) {
  OSTEON_RETURN_IF_ERROR(check_stream_header(data, size, source));
  ByteReader in(data, size);
  in.skip(16);
  double origin[3], step = 0;
  for (double& o : origin) in.read_le(&o);
  in.read_le(&step);
  if (!(step > 0) || !std::isfinite(step) || !std::isfinite(origin[0]) ||
      !std::isfinite(origin[1]) || !std::isfinite(origin[2])) {
    return error(ErrorCode::kInvalidData, source, "invalid quantization grid", "byte 16");
  }
  QuantizationGrid grid;
  grid.origin = {float(origin[0]), float(origin[1]), float(origin[2])};
  grid.step = step;
  return grid;
}

}  // namespace osteon
