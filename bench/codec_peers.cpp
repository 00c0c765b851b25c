// SPDX-License-Identifier: Apache-2.0
#include "codec_peers.hpp"

#include <cmath>
#include <cstring>
#include <memory>

#include <draco/compression/decode.h>
#include <draco/compression/encode.h>
#include <draco/mesh/mesh.h>
#include <meshoptimizer.h>
#include <zlib.h>

#include "osteon/io.hpp"

// Draco and meshoptimizer as bench/codec_bench runs them; see codec_peers.hpp.

namespace osteon_bench {

namespace {

/// Inflates a gzip stream into `out` (sized by the caller); false when it does not fill it exactly.
bool gunzip(const std::vector<uint8_t>& in, std::vector<uint8_t>& out) {
  z_stream z{};
  if (inflateInit2(&z, 15 + 16) != Z_OK) return false;
  z.next_in = const_cast<uint8_t*>(in.data());
  z.avail_in = static_cast<uInt>(in.size());
  z.next_out = out.data();
  z.avail_out = static_cast<uInt>(out.size());
  int rc = inflate(&z, Z_FINISH);
  bool ok = rc == Z_STREAM_END && z.total_out == out.size();
  inflateEnd(&z);
  return ok;
}

/// The mesh as Draco takes it: one point per vertex (identity mapping), float32 positions, and
/// with `with_ids` a one-component uint32 generic attribute holding each vertex's input index.
std::unique_ptr<draco::Mesh> to_draco(const osteon::Mesh& mesh, bool with_ids) {
  auto dm = std::make_unique<draco::Mesh>();
  const uint32_t n = static_cast<uint32_t>(mesh.vertex_count());
  dm->set_num_points(n);
  draco::GeometryAttribute position;
  position.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false,
                sizeof(float) * 3, 0);
  draco::PointAttribute* pos = dm->attribute(dm->AddAttribute(position, true, n));
  for (uint32_t i = 0; i < n; ++i)
    pos->SetAttributeValue(draco::AttributeValueIndex(i), &mesh.positions[i]);
  if (with_ids) {
    draco::GeometryAttribute id;
    id.Init(draco::GeometryAttribute::GENERIC, nullptr, 1, draco::DT_UINT32, false,
            sizeof(uint32_t), 0);
    draco::PointAttribute* ids = dm->attribute(dm->AddAttribute(id, true, n));
    for (uint32_t i = 0; i < n; ++i) ids->SetAttributeValue(draco::AttributeValueIndex(i), &i);
  }
  dm->SetNumFaces(mesh.triangle_count());
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    draco::Mesh::Face face;
    for (int k = 0; k < 3; ++k) face[k] = draco::PointIndex(mesh.indices[3 * t + k]);
    dm->SetFace(draco::FaceIndex(static_cast<uint32_t>(t)), face);
  }
  return dm;
}

void configure_draco(draco::Encoder& encoder, int bits, int level) {
  encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, bits);
  encoder.SetSpeedOptions(10 - level, 10 - level);  // draco_encoder's -cl
}

DracoResult run_level(const draco::Mesh& dm, int bits, int level, const Timing& timing,
                      const std::string& stream) {
  DracoResult r;
  draco::EncoderBuffer buffer;
  r.encode_ms = best_ms(timing, [&] {
    draco::Encoder encoder;
    configure_draco(encoder, bits, level);
    buffer.Clear();
    draco::Status status = encoder.EncodeMeshToBuffer(dm, &buffer);
    if (!status.ok()) r.error = std::string("encode: ") + status.error_msg();
    return status.ok();
  });
  if (!r.error.empty()) return r;
  r.bytes = buffer.size();
  r.decode_ms = best_ms(timing, [&] {
    draco::DecoderBuffer in;
    in.Init(buffer.data(), buffer.size());
    draco::Decoder decoder;
    auto decoded = decoder.DecodeMeshFromBuffer(&in);
    if (!decoded.ok()) {
      r.error = std::string("decode: ") + decoded.status().error_msg();
      return false;
    }
    r.decoded_triangles = decoded.value()->num_faces();
    return true;
  });
  if (osteon::write_file_atomic(stream, buffer.data(), buffer.size()).ok()) r.stream = stream;
  return r;
}

/// Draco's position error, measured: a companion stream (cl7 settings) carries each vertex's input
/// index, so every decoded point names the input vertex it came from.
double draco_max_error(const osteon::Mesh& mesh, int bits, std::string* note) {
  auto dm = to_draco(mesh, true);
  draco::Encoder encoder;
  configure_draco(encoder, bits, kDracoLevels[0]);
  encoder.SetAttributeQuantization(draco::GeometryAttribute::GENERIC, 0);  // ids stay exact
  draco::EncoderBuffer buffer;
  if (!encoder.EncodeMeshToBuffer(*dm, &buffer).ok()) {
    *note = "companion encode failed";
    return -1;
  }
  draco::DecoderBuffer in;
  in.Init(buffer.data(), buffer.size());
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&in);
  if (!decoded.ok()) {
    *note = "companion decode failed";
    return -1;
  }
  const draco::Mesh& back = *decoded.value();
  const draco::PointAttribute* pos = back.GetNamedAttribute(draco::GeometryAttribute::POSITION);
  const draco::PointAttribute* ids = back.GetNamedAttribute(draco::GeometryAttribute::GENERIC);
  if (!pos || !ids || pos->data_type() != draco::DT_FLOAT32 ||
      ids->data_type() != draco::DT_UINT32) {
    *note = "companion stream lacks its attributes";
    return -1;
  }
  double max_error = 0;
  for (draco::PointIndex p(0); p < back.num_points(); ++p) {
    float xyz[3];
    uint32_t id = 0;
    pos->GetValue(pos->mapped_index(p), xyz);
    ids->GetValue(ids->mapped_index(p), &id);
    if (id >= mesh.vertex_count()) {
      *note = "companion stream names a vertex out of range";
      return -1;
    }
    const osteon::Vec3& v = mesh.positions[id];
    max_error = std::max({max_error, std::fabs(double(xyz[0]) - v.x),
                          std::fabs(double(xyz[1]) - v.y), std::fabs(double(xyz[2]) - v.z)});
  }
  return max_error;
}

}  // namespace

DracoRun run_draco(const osteon::Mesh& mesh, int bits, const Timing& timing,
                   const std::string& stream_stem) {
  DracoRun run;
  auto dm = to_draco(mesh, false);
  for (int i = 0; i < 2; ++i)
    run.level[i] = run_level(*dm, bits, kDracoLevels[i], timing,
                             stream_stem + "_cl" + std::to_string(kDracoLevels[i]) + ".drc");
  dm.reset();
  run.max_error = draco_max_error(mesh, bits, &run.max_error_note);
  return run;
}

size_t draco_connectivity_bytes(const osteon::Mesh& mesh, int bits) {
  if (mesh.positions.size() < 2) return 0;
  osteon::Mesh flat = mesh;
  // The first two positions keep a nonzero range for the quantizer; every other is the first.
  std::fill(flat.positions.begin() + 2, flat.positions.end(), flat.positions[0]);
  auto dm = to_draco(flat, false);
  Timing once;
  once.repeat = 1;
  once.min_seconds = 0;
  DracoResult r = run_level(*dm, bits, kDracoLevels[1], once, "");
  return r.error.empty() ? r.bytes : 0;
}

osteon::QuantizationGrid grid_for(const osteon::Mesh& mesh, int bits) {
  osteon::Aabb box = osteon::bounding_box(mesh);
  double side = std::max({double(box.max.x) - box.min.x, double(box.max.y) - box.min.y,
                          double(box.max.z) - box.min.z});
  osteon::QuantizationGrid grid;
  grid.origin = box.min;
  grid.step = side > 0 ? side / double((uint64_t{1} << bits) - 1) : 1.0;
  return grid;
}

MeshoptResult run_meshopt(const osteon::Mesh& mesh, int bits, const Timing& timing) {
  MeshoptResult r;
  const size_t index_count = mesh.indices.size();
  const size_t vertex_count = mesh.vertex_count();
  const size_t components = 3;
  const size_t stride = bits <= 16 ? 8 : 12;  // uint16 x 3 + padding, or uint32 x 3
  osteon::QuantizationGrid grid = grid_for(mesh, bits);
  const long long max_cell = (1LL << bits) - 1;
  std::vector<uint8_t> stream;
  std::vector<unsigned int> remap;
  size_t unique = 0;

  r.encode_ms = best_ms(timing, [&] {
    std::vector<unsigned int> indices(mesh.indices.begin(), mesh.indices.end());
    meshopt_optimizeVertexCache(indices.data(), indices.data(), index_count, vertex_count);
    std::vector<uint8_t> quantized(vertex_count * stride, 0);
    for (size_t i = 0; i < vertex_count; ++i) {
      const osteon::Vec3& p = mesh.positions[i];
      double xyz[3] = {p.x - double(grid.origin.x), p.y - double(grid.origin.y),
                       p.z - double(grid.origin.z)};
      for (size_t c = 0; c < components; ++c) {
        long long cell = std::clamp(std::llround(xyz[c] / grid.step), 0LL, max_cell);
        uint32_t q = static_cast<uint32_t>(cell);
        if (stride == 8) {
          uint16_t q16 = static_cast<uint16_t>(q);
          std::memcpy(&quantized[i * stride + 2 * c], &q16, 2);
        } else {
          std::memcpy(&quantized[i * stride + 4 * c], &q, 4);
        }
      }
    }
    remap.assign(vertex_count, 0);
    unique =
        meshopt_optimizeVertexFetchRemap(remap.data(), indices.data(), index_count, vertex_count);
    std::vector<uint8_t> vertices(unique * stride);
    meshopt_remapVertexBuffer(vertices.data(), quantized.data(), vertex_count, stride,
                              remap.data());
    meshopt_remapIndexBuffer(indices.data(), indices.data(), index_count, remap.data());

    std::vector<uint8_t> vbuf(meshopt_encodeVertexBufferBound(unique, stride));
    vbuf.resize(
        meshopt_encodeVertexBuffer(vbuf.data(), vbuf.size(), vertices.data(), unique, stride));
    std::vector<uint8_t> ibuf(meshopt_encodeIndexBufferBound(index_count, unique));
    ibuf.resize(meshopt_encodeIndexBuffer(ibuf.data(), ibuf.size(), indices.data(), index_count));
    if (r.buffers.empty()) {  // once: the best of the timed runs is one without this copy
      const uint32_t sizes[3] = {uint32_t(unique), uint32_t(index_count), uint32_t(stride)};
      r.buffers.resize(12);
      std::memcpy(r.buffers.data(), sizes, 12);
      r.buffers.insert(r.buffers.end(), vertices.begin(), vertices.end());
      const auto* index_bytes = reinterpret_cast<const uint8_t*>(indices.data());
      r.buffers.insert(r.buffers.end(), index_bytes, index_bytes + 4 * index_count);
    }
    std::vector<uint8_t> raw(12);
    uint32_t header[3] = {uint32_t(unique), uint32_t(index_count), uint32_t(vbuf.size())};
    std::memcpy(raw.data(), header, 12);
    raw.insert(raw.end(), vbuf.begin(), vbuf.end());
    raw.insert(raw.end(), ibuf.begin(), ibuf.end());
    stream = gzip(raw, 9);
    return !stream.empty();
  });
  if (r.encode_ms < 0) {
    r.error = "gzip failed";
    return r;
  }
  r.bytes = stream.size();

  // The decoder sizes its buffer from the raw size: a page knows it from its container, here it
  // is the gzip trailer's ISIZE.
  uint32_t raw_size = 0;
  std::memcpy(&raw_size, stream.data() + stream.size() - 4, 4);
  std::vector<uint8_t> vertices, raw;
  std::vector<unsigned int> indices;
  r.decode_ms = best_ms(timing, [&] {
    raw.assign(raw_size, 0);
    if (!gunzip(stream, raw)) return false;
    uint32_t header[3];
    std::memcpy(header, raw.data(), 12);
    vertices.assign(size_t(header[0]) * stride, 0);
    indices.assign(header[1], 0);
    if (meshopt_decodeVertexBuffer(vertices.data(), header[0], stride, raw.data() + 12,
                                   header[2]) != 0)
      return false;
    return meshopt_decodeIndexBuffer(indices.data(), header[1], sizeof(unsigned int),
                                     raw.data() + 12 + header[2], raw.size() - 12 - header[2]) == 0;
  });
  if (r.decode_ms < 0) {
    r.error = "decode failed";
    return r;
  }
  for (size_t i = 0; i < vertex_count; ++i) {
    if (remap[i] == ~0u) continue;  // unreferenced
    const uint8_t* q = &vertices[size_t(remap[i]) * stride];
    const float input[3] = {mesh.positions[i].x, mesh.positions[i].y, mesh.positions[i].z};
    const float origin[3] = {grid.origin.x, grid.origin.y, grid.origin.z};
    for (size_t c = 0; c < components; ++c) {
      uint32_t value = 0;
      if (stride == 8) {
        uint16_t q16;
        std::memcpy(&q16, q + 2 * c, 2);
        value = q16;
      } else {
        std::memcpy(&value, q + 4 * c, 4);
      }
      float decoded = static_cast<float>(origin[c] + value * grid.step);
      r.max_error = std::max(r.max_error, std::fabs(double(decoded) - input[c]));
    }
  }
  return r;
}

}  // namespace osteon_bench
