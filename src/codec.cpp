// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include "byte_io.hpp"
#include "connectivity.hpp"
#include "geometry.hpp"
#include "osteon/codec.hpp"

// The container around the codec's sections: header, section lengths, CRC-32. docs/FORMAT.md
// specifies every byte; tests/codec_test.cpp freezes it with golden files.

namespace osteon {

namespace {

constexpr uint8_t kMagic[4] = {'O', 'S', 'T', 'M'};
constexpr uint8_t kVersion = 1;
constexpr size_t kHeaderBytes = 4 + 1 + 1 + 2 + 4 + 4 + 4 * 8 + 3 * 4;  // 60
constexpr size_t kChecksumBytes = 4;
/// A stream may describe at most this many triangles per byte of its own size: far above what
/// any real mesh reaches (a few bits per triangle), and it bounds what hostile bytes can allocate.
constexpr uint64_t kMaxTrianglesPerByte = 1024;
constexpr uint32_t kMaxTriangles = uint32_t{1} << 28;

uint32_t crc32(const uint8_t* data, size_t size) {
  static const std::array<uint32_t, 256> table = [] {
    std::array<uint32_t, 256> t{};
    for (uint32_t i = 0; i < 256; ++i) {
      uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  uint32_t crc = 0xffffffffu;
  for (size_t i = 0; i < size; ++i) crc = table[(crc ^ data[i]) & 0xff] ^ (crc >> 8);
  return crc ^ 0xffffffffu;
}

template <class T>
void put_le(std::vector<uint8_t>* out, T value) {
  uint8_t bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) std::reverse(bytes, bytes + sizeof(T));
  out->insert(out->end(), bytes, bytes + sizeof(T));
}

Status invalid(const std::string& what) {
  return error(ErrorCode::kInvalidArgument, "encode", what);
}

}  // namespace

std::vector<Vec3> compute_vertex_normals(const Mesh& mesh) {
  std::vector<Vec3> normals(mesh.positions.size(), Vec3{0, 0, 0});
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    uint32_t a = mesh.indices[3 * t], b = mesh.indices[3 * t + 1], c = mesh.indices[3 * t + 2];
    const Vec3 &p = mesh.positions[a], &q = mesh.positions[b], &r = mesh.positions[c];
    float ux = q.x - p.x, uy = q.y - p.y, uz = q.z - p.z;
    float vx = r.x - p.x, vy = r.y - p.y, vz = r.z - p.z;
    // The cross product's length is twice the area: summing it weights by area.
    Vec3 n{uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx};
    for (uint32_t v : {a, b, c}) {
      normals[v].x += n.x;
      normals[v].y += n.y;
      normals[v].z += n.z;
    }
  }
  for (Vec3& n : normals) {
    float length = std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    if (length > 0) n = {n.x / length, n.y / length, n.z / length};
  }
  return normals;
}

Result<std::vector<uint8_t>> encode(const Mesh& input, const EncodeOptions& options,
                                    EncodeReport* report) {
  for (uint32_t index : input.indices) {
    if (index >= input.positions.size()) {
      return invalid("triangle index " + std::to_string(index) + " is out of range (" +
                     std::to_string(input.positions.size()) + " vertices)");
    }
  }
  if (input.indices.size() % 3 != 0) return invalid("the index count is not a multiple of 3");
  for (const Vec3& p : input.positions) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      return invalid("the mesh has a NaN or infinite position");
    }
  }
  if (input.triangle_count() > kMaxTriangles) {
    return invalid("more than 2^28 triangles in one mesh: split it into components first");
  }
  if (options.normals) {
    return error(ErrorCode::kUnsupported, "encode", "transmitted normals are not implemented yet");
  }

  Mesh mesh;
  mesh.positions = input.positions;
  mesh.indices = input.indices;
  EncodeReport r;
  r.degenerate_removed = remove_degenerate_triangles(mesh);
  r.unreferenced_removed = remove_unreferenced_vertices(mesh);
  OSTEON_ASSIGN_OR_RETURN(QuantizationGrid grid, detail::choose_grid(mesh.positions, options));
  detail::QuantizedPositions q = detail::quantize(mesh.positions, grid);

  uint32_t vertex_count = static_cast<uint32_t>(mesh.positions.size());
  OSTEON_ASSIGN_OR_RETURN(detail::ConnectivityEncoding connectivity,
                          detail::encode_connectivity(mesh.indices, vertex_count));
  detail::QuantizedPositions ordered;
  ordered.xyz.resize(q.xyz.size());
  for (uint32_t d = 0; d < vertex_count; ++d) {
    uint32_t v = connectivity.vertex_order[d];
    for (int k = 0; k < 3; ++k) ordered.xyz[3 * size_t{d} + k] = q.xyz[3 * size_t{v} + k];
  }
  std::vector<uint8_t> geometry;
  detail::encode_geometry(connectivity.decoded_indices, ordered, &geometry);

  std::vector<uint8_t> out;
  out.reserve(kHeaderBytes + connectivity.bytes.size() + geometry.size() + kChecksumBytes);
  out.insert(out.end(), kMagic, kMagic + 4);
  out.push_back(kVersion);
  out.push_back(0);  // flags: bit 0 = normals section present
  put_le<uint16_t>(&out, 0);
  put_le<uint32_t>(&out, vertex_count);
  put_le<uint32_t>(&out, static_cast<uint32_t>(mesh.triangle_count()));
  put_le<double>(&out, grid.origin.x);
  put_le<double>(&out, grid.origin.y);
  put_le<double>(&out, grid.origin.z);
  put_le<double>(&out, grid.step);
  put_le<uint32_t>(&out, static_cast<uint32_t>(connectivity.bytes.size()));
  put_le<uint32_t>(&out, static_cast<uint32_t>(geometry.size()));
  put_le<uint32_t>(&out, 0);  // normals section length
  out.insert(out.end(), connectivity.bytes.begin(), connectivity.bytes.end());
  out.insert(out.end(), geometry.begin(), geometry.end());
  put_le<uint32_t>(&out, crc32(out.data(), out.size()));

  if (report != nullptr) {
    r.bytes = out.size();
    r.connectivity_bytes = connectivity.bytes.size();
    r.geometry_bytes = geometry.size();
    r.vertices = vertex_count;
    r.triangles = mesh.triangle_count();
    r.grid = grid;
    r.grid_step = grid.step;
    if (vertex_count > 0) {
      r.connectivity_bits_per_vertex = 8.0 * double(r.connectivity_bytes) / vertex_count;
      r.geometry_bits_per_vertex = 8.0 * double(r.geometry_bytes) / vertex_count;
    }
    std::vector<Vec3> back = detail::dequantize(q, grid);
    for (size_t i = 0; i < back.size(); ++i) {
      r.max_error = std::max({r.max_error, std::fabs(double(back[i].x) - mesh.positions[i].x),
                              std::fabs(double(back[i].y) - mesh.positions[i].y),
                              std::fabs(double(back[i].z) - mesh.positions[i].z)});
    }
    *report = r;
  }
  return out;
}

Result<Mesh> decode(const uint8_t* data, size_t size, const std::string& source) {
  if (size < kHeaderBytes + kChecksumBytes) {
    return error(ErrorCode::kInvalidData, source,
                 "too short for an osteon stream (" + std::to_string(size) + " bytes, at least " +
                     std::to_string(kHeaderBytes + kChecksumBytes) + ")",
                 at_byte(size));
  }
  if (std::memcmp(data, kMagic, 4) != 0) {
    return error(ErrorCode::kInvalidData, source, "not an osteon stream (wrong magic)", "byte 0");
  }
  if (data[4] != kVersion) {
    return error(ErrorCode::kUnsupported, source,
                 "stream version " + std::to_string(data[4]) + " (this decoder reads version " +
                     std::to_string(kVersion) + ")",
                 "byte 4");
  }
  uint32_t stored_crc = ByteReader::load<uint32_t>(data + size - 4, std::endian::little);
  if (crc32(data, size - 4) != stored_crc) {
    return error(ErrorCode::kInvalidData, source, "checksum mismatch: the stream is corrupt",
                 at_byte(size - 4));
  }
  ByteReader in(data, size - kChecksumBytes);
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
  if (flags != 0 || reserved != 0) {
    return error(ErrorCode::kUnsupported, source, "unknown flags in the header", "byte 5");
  }
  if (triangle_count > kMaxTriangles ||
      uint64_t{triangle_count} > kMaxTrianglesPerByte * uint64_t{size} ||
      uint64_t{vertex_count} > 3 * uint64_t{triangle_count}) {
    return error(ErrorCode::kInvalidData, source,
                 "implausible counts: " + std::to_string(vertex_count) + " vertices, " +
                     std::to_string(triangle_count) + " triangles in " + std::to_string(size) +
                     " bytes",
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
      std::vector<uint32_t> indices,
      detail::decode_connectivity(connectivity_in, vertex_count, triangle_count, source));
  ByteReader geometry_in(data + base + lengths[0], lengths[1]);
  OSTEON_ASSIGN_OR_RETURN(detail::QuantizedPositions q,
                          detail::decode_geometry(geometry_in, indices, vertex_count, source));
  QuantizationGrid grid;
  grid.origin = {float(origin[0]), float(origin[1]), float(origin[2])};
  grid.step = step;
  Mesh mesh;
  mesh.positions = detail::dequantize(q, grid);
  mesh.indices = std::move(indices);
  mesh.stored_vertices = vertex_count;
  mesh.normals = compute_vertex_normals(mesh);
  return mesh;
}

}  // namespace osteon
