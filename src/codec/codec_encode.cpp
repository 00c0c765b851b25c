// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <cmath>
#include <cstring>

#include "codec/codec_internal.hpp"
#include "codec/connectivity.hpp"
#include "codec/geometry.hpp"
#include "codec/normals.hpp"
#include "core/byte_io.hpp"
#include "osteon/codec.hpp"

// The codec's encoder: cleans the mesh, quantizes it, codes connectivity then geometry in the
// connectivity's vertex order, and writes the container (docs/FORMAT.md, "Mesh stream").

static_assert(osteon::kStreamVersion == osteon::detail::kStreamVersion,
              "the public stream version is the one the encoder writes");

namespace osteon {

namespace {

Status invalid(const std::string& what) {
  return error(ErrorCode::kInvalidArgument, "encode", what);
}

/// Whether some vertex is referenced by no triangle (the indices checked to be in range).
bool has_unreferenced_vertices(const Mesh& mesh) {
  std::vector<uint8_t> used(mesh.positions.size(), 0);
  for (uint32_t index : mesh.indices) used[index] = 1;
  return std::find(used.begin(), used.end(), 0) != used.end();
}

}  // namespace

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
  if (input.triangle_count() > detail::kMaxTriangles) {
    return invalid("more than 2^28 triangles in one mesh: split it into components first");
  }
  if (options.effort < 0 || options.effort > 1) {
    return invalid("effort must be 0 or 1, not " + std::to_string(options.effort));
  }
  const bool search = options.effort > 0;
  if (options.normals && (options.normal_bits < 8 || options.normal_bits > 16)) {
    return invalid("normal bits must be between 8 and 16, not " +
                   std::to_string(options.normal_bits));
  }

  if (options.normals && input.normals.size() == input.positions.size()) {
    for (const Vec3& n : input.normals) {
      if (!std::isfinite(n.x) || !std::isfinite(n.y) || !std::isfinite(n.z)) {
        return invalid("the mesh has a NaN or infinite normal");
      }
    }
  }

  // The mesh as coded: the input itself, or a copy without its degenerate triangles and
  // unreferenced vertices where it has any (most meshes have none).
  EncodeReport r;
  Mesh cleaned;
  const bool clean = count_degenerate_triangles(input) == 0 && !has_unreferenced_vertices(input);
  if (!clean) {
    cleaned.positions = input.positions;
    cleaned.indices = input.indices;
    if (options.normals && input.normals.size() == input.positions.size()) {
      cleaned.normals = input.normals;
    }
    r.degenerate_removed = remove_degenerate_triangles(cleaned);
    r.unreferenced_removed = remove_unreferenced_vertices(cleaned);
  }
  const Mesh& mesh = clean ? input : cleaned;
  OSTEON_ASSIGN_OR_RETURN(QuantizationGrid grid, choose_grid(mesh.positions, options));
  detail::QuantizedPositions q = detail::quantize(mesh.positions, grid);

  uint32_t vertex_count = static_cast<uint32_t>(mesh.positions.size());
  OSTEON_ASSIGN_OR_RETURN(detail::ConnectivityEncoding connectivity,
                          detail::encode_connectivity(mesh.indices, vertex_count, search));
  detail::QuantizedPositions ordered;
  ordered.xyz.resize(q.xyz.size());
  for (uint32_t d = 0; d < vertex_count; ++d) {
    uint32_t v = connectivity.vertex_order[d];
    for (int k = 0; k < 3; ++k) ordered.xyz[3 * size_t{d} + k] = q.xyz[3 * size_t{v} + k];
  }
  // The sections' rANS states form one chain (docs/FORMAT.md, "Symbol section"), written from the
  // last section to the first: each starts its state 0 where the next one's begins.
  std::vector<uint8_t> normals;
  uint32_t chain = detail::kRansLow;
  if (options.normals) {
    const bool given = mesh.normals.size() == mesh.positions.size();
    const std::vector<Vec3> computed = given ? std::vector<Vec3>() : compute_vertex_normals(mesh);
    const std::vector<Vec3>& vertex_normals = given ? mesh.normals : computed;
    std::vector<Vec3> ordered_normals(vertex_count);
    for (uint32_t d = 0; d < vertex_count; ++d) {
      ordered_normals[d] = vertex_normals[connectivity.vertex_order[d]];
    }
    chain = detail::encode_normals(connectivity.decoded_indices, ordered, ordered_normals,
                                   options.normal_bits, &normals);
  }
  std::vector<uint8_t> geometry;
  const detail::GeometryChoice chosen = detail::encode_geometry(
      connectivity.decoded_newest, ordered, grid.lattice, &geometry, chain, search);
  std::vector<uint8_t> connectivity_bytes = std::move(connectivity.prefix);
  connectivity.symbols->append_to(&connectivity_bytes, chosen.first_state);

  // The compact header (docs/FORMAT.md): a small mesh's stream is a few hundred bytes, of
  // which version 6's fixed fields took 64 with the checksum.
  std::vector<uint8_t> out;
  out.reserve(detail::kCompactHeaderBytes + 16 /* the varints' further bytes */ +
              connectivity_bytes.size() + geometry.size() + normals.size() +
              detail::kStreamChecksumBytes);
  ByteWriter writer(&out);
  writer.write_bytes(detail::kStreamMagic, 4);
  writer.write_le<uint8_t>(detail::kStreamVersion);
  // A step that is a float (choose_grid makes it one when it picks the grid) is stored as one.
  const bool float_step = detail::is_float(grid.step);
  writer.write_le<uint8_t>((normals.empty() ? 0 : detail::kFlagNormals) |
                           (float_step ? detail::kFlagFloatStep : 0));
  writer.write_varint(vertex_count);
  writer.write_varint(mesh.triangle_count());
  writer.write_le<float>(grid.origin.x);  // the grid's origin is a float: exact
  writer.write_le<float>(grid.origin.y);
  writer.write_le<float>(grid.origin.z);
  if (float_step) {
    writer.write_le<float>(float(grid.step));
  } else {
    writer.write_le<double>(grid.step);
  }
  writer.write_varint(connectivity_bytes.size());
  if (!normals.empty()) writer.write_varint(normals.size());
  writer.write_bytes(connectivity_bytes.data(), connectivity_bytes.size());
  writer.write_bytes(geometry.data(), geometry.size());
  writer.write_bytes(normals.data(), normals.size());
  writer.write_le<uint32_t>(detail::crc32(out.data(), out.size()));

  if (report != nullptr) {
    r.bytes = out.size();
    r.connectivity_bytes = connectivity_bytes.size();
    r.geometry_bytes = geometry.size();
    r.prediction_mode = chosen.mode;
    r.shape_scale = chosen.shape_scale;
    r.shape_apex = chosen.shape_apex;
    r.extrapolation = chosen.extrapolation;
    r.curvature = chosen.curvature;
    r.geometry_passes = vertex_count > 0 ? double(chosen.predicted) / vertex_count : 0;
    r.connectivity_models = static_cast<int>(connectivity.models_planned);
    r.normal_bytes = normals.size();
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

}  // namespace osteon
