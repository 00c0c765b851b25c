// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
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
    OSTEON_UNROLL
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

/// A stream's header fields (docs/FORMAT.md): up to version 6 fixed, from version 7 compact.
struct StreamHeader {
  uint8_t version = 0;
  bool has_normals = false;
  uint32_t vertex_count = 0, triangle_count = 0;
  QuantizationGrid grid;
  uint64_t lengths[3] = {0, 0, 0};  // connectivity, geometry, normals
  size_t sections = 0;              // where the connectivity section starts
};

Status header_error(ErrorCode code, const std::string& source, const char* what, size_t at) {
  return error(code, source, what, at_byte(at));
}

/// Reads and checks the header of the stream `data` (`size` bytes, its checksum included; the
/// checksum itself is not checked here): magic, version, flags, counts, grid, section lengths.
OSTEON_NOINLINE OSTEON_COLD_FUNCTION Status read_header(const uint8_t* data, size_t size,
                                                        const std::string& source,
                                                        StreamHeader* h) {
  if (size < detail::kCompactHeaderBytes + detail::kStreamChecksumBytes) {
    return error(
        ErrorCode::kInvalidData, source,
        detail::message("too short for an osteon stream (% bytes, at least %)",
                        {size, detail::kCompactHeaderBytes + detail::kStreamChecksumBytes}),
        at_byte(size));
  }
  if (std::memcmp(data, detail::kStreamMagic, 4) != 0) {
    return error(ErrorCode::kInvalidData, source, "not an osteon stream (wrong magic)", "byte 0");
  }
  h->version = data[4];
  if (h->version < detail::kOldestStreamVersion || h->version > detail::kStreamVersion) {
    return error(
        ErrorCode::kUnsupported, source,
        detail::message("stream version % (this decoder reads versions % to %)",
                        {h->version, detail::kOldestStreamVersion, detail::kStreamVersion}),
        "byte 4");
  }
  ByteReader in(data, size - detail::kStreamChecksumBytes);
  in.skip(5);
  uint8_t flags = 0;
  in.read_le(&flags);
  const uint8_t known = detail::kFlagNormals | (h->version >= 8 ? detail::kFlagFloatStep : 0);
  if ((flags & ~known) != 0) {
    return header_error(ErrorCode::kUnsupported, source, "unknown flags in the header", 5);
  }
  h->has_normals = (flags & detail::kFlagNormals) != 0;
  bool ok = true;
  size_t counts_at = 0, grid_at = 0, lengths_at = 0, normals_at = 0;
  double origin[3] = {0, 0, 0};
  if (h->version < detail::kCompactHeaderVersion) {  // 60 bytes of fixed fields
    uint16_t reserved = 0;
    uint32_t lengths[3];
    ok = in.read_le(&reserved);
    counts_at = in.offset();
    ok = ok && in.read_le(&h->vertex_count) && in.read_le(&h->triangle_count);
    grid_at = in.offset();
    for (double& o : origin) ok = ok && in.read_le(&o);
    ok = ok && in.read_le(&h->grid.step);
    lengths_at = in.offset();
    for (uint32_t& l : lengths) ok = ok && in.read_le(&l);
    if (!ok) return header_error(ErrorCode::kInvalidData, source, "truncated header", in.offset());
    if (reserved != 0) {
      return header_error(ErrorCode::kUnsupported, source, "unknown flags in the header", 5);
    }
    std::copy(lengths, lengths + 3, h->lengths);
    normals_at = lengths_at + 8;
  } else {
    uint64_t vertices = 0, triangles = 0;
    float compact[3];
    counts_at = in.offset();
    ok = in.read_varint(&vertices) && in.read_varint(&triangles);
    grid_at = in.offset();
    for (float& o : compact) ok = ok && in.read_le(&o);
    float float_step = 0;  // flags bit 1: the step as a float
    if ((flags & detail::kFlagFloatStep) != 0) {
      ok = ok && in.read_le(&float_step);
      h->grid.step = float_step;
    } else {
      ok = ok && in.read_le(&h->grid.step);
    }
    lengths_at = in.offset();
    ok = ok && in.read_varint(&h->lengths[0]);
    normals_at = in.offset();
    ok = ok && (!h->has_normals || in.read_varint(&h->lengths[2]));
    if (!ok) return header_error(ErrorCode::kInvalidData, source, "truncated header", in.offset());
    if (vertices > UINT32_MAX || triangles > UINT32_MAX) {
      return header_error(ErrorCode::kInvalidData, source, "implausible counts", counts_at);
    }
    h->vertex_count = static_cast<uint32_t>(vertices);
    h->triangle_count = static_cast<uint32_t>(triangles);
    std::copy(compact, compact + 3, origin);
    // The geometry section is what the other two leave.
    const uint64_t rest = in.remaining();
    if (h->lengths[0] > rest || h->lengths[2] > rest - h->lengths[0]) {
      return header_error(ErrorCode::kInvalidData, source,
                          "section lengths exceed the stream's size", lengths_at);
    }
    h->lengths[1] = rest - h->lengths[0] - h->lengths[2];
  }
  h->sections = in.offset();
  if (h->has_normals != (h->lengths[2] != 0)) {
    return header_error(ErrorCode::kInvalidData, source,
                        "the normals flag and the normals section's length disagree", normals_at);
  }
  if (h->triangle_count > detail::kMaxTriangles ||
      uint64_t{h->triangle_count} > detail::kMaxTrianglesPerByte * uint64_t{size} ||
      uint64_t{h->vertex_count} > 3 * uint64_t{h->triangle_count}) {
    return error(ErrorCode::kInvalidData, source,
                 detail::message("implausible counts: % vertices, % triangles in % bytes",
                                 {h->vertex_count, h->triangle_count, size}),
                 at_byte(counts_at));
  }
  const double step = h->grid.step;
  if (!(step > 0) || !std::isfinite(step) || !std::isfinite(origin[0]) ||
      !std::isfinite(origin[1]) || !std::isfinite(origin[2])) {
    return header_error(ErrorCode::kInvalidData, source, "invalid quantization grid", grid_at);
  }
  h->grid.origin = {float(origin[0]), float(origin[1]), float(origin[2])};
  // Versions 1 to 6 state all three lengths (version 7's geometry length is the rest).
  if (h->lengths[0] + h->lengths[1] + h->lengths[2] != in.remaining()) {
    return header_error(ErrorCode::kInvalidData, source,
                        "section lengths do not add up to the stream's size", lengths_at);
  }
  return Status();
}

}  // namespace

Result<Mesh> decode(const uint8_t* data, size_t size, const std::string& source) {
  StreamHeader h;
  OSTEON_RETURN_IF_ERROR(read_header(data, size, source, &h));
  uint32_t stored_crc = ByteReader::load<uint32_t>(data + size - 4, std::endian::little);
  if (detail::crc32(data, size - 4) != stored_crc) {
    return error(ErrorCode::kInvalidData, source, "checksum mismatch: the stream is corrupt",
                 at_byte(size - 4));
  }
  const size_t base = h.sections;
  const uint32_t vertex_count = h.vertex_count;
  ByteReader connectivity_in(data + base, h.lengths[0]);
  OSTEON_ASSIGN_OR_RETURN(detail::DecodedConnectivity connectivity,
                          detail::decode_connectivity(connectivity_in, vertex_count,
                                                      h.triangle_count, h.version, source));
  ByteReader geometry_in(data + base + h.lengths[0], h.lengths[1]);
  uint32_t chain = connectivity.last_state;  // version 8: one chain of rANS states
  OSTEON_ASSIGN_OR_RETURN(detail::QuantizedPositions q,
                          detail::decode_geometry(geometry_in, connectivity.newest, vertex_count,
                                                  h.version, source, &chain, h.has_normals));
  connectivity.newest = detail::NewestTriangles();  // free it before the normals' arrays
  std::vector<uint32_t>& indices = connectivity.indices;
  Mesh mesh;
  mesh.positions = detail::dequantize(q, h.grid);
  mesh.indices = std::move(indices);
  mesh.stored_vertices = vertex_count;
  if (h.has_normals) {
    ByteReader normals_in(data + base + h.lengths[0] + h.lengths[1], h.lengths[2]);
    OSTEON_ASSIGN_OR_RETURN(mesh.normals, detail::decode_normals(normals_in, mesh.indices, q,
                                                                 h.version, source, chain));
  } else {
    mesh.normals = compute_vertex_normals(mesh);
  }
  return mesh;
}

Result<QuantizationGrid> stream_grid(const uint8_t* data, size_t size, const std::string& source) {
  StreamHeader h;
  OSTEON_RETURN_IF_ERROR(read_header(data, size, source, &h));
  return h.grid;
}

}  // namespace osteon
