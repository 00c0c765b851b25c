// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "codec/entropy.hpp"
#include "core/byte_io.hpp"
#include "osteon/status.hpp"

// The connectivity stage of the codec (src/codec/edgebreaker_encode.cpp,
// src/codec/edgebreaker_decode.cpp, src/corner_table.*): any triangle list in, the same triangles
// out, vertices renumbered.

namespace osteon::detail {

/// What the geometry stage's parallelogram predictor needs of the connectivity (docs/FORMAT.md,
/// "Geometry section"), which the connectivity decoder builds as it writes the triangles: every
/// triangle filed under its newest (largest) vertex m, with the other two vertices n and p (in
/// the triangle's corner order after m) and o, the vertex across the edge (n, p) in the
/// neighbouring triangle, where that edge is manifold (one triangle each way, as the encoder kept
/// it) and o < m; else kNoVertexId.
///
///            o
///           / \         m's parallelogram across (n, p): n + p - o
///          p---n
///           \ /
///            m
inline constexpr uint32_t kNoVertexId = 0xFFFFFFFFu;

struct NewestTriangle {
  uint32_t n, p, o;
};

struct NewestTriangles {
  /// V + 1 offsets: vertex v's triangles are entries[first[v] .. first[v + 1]), in triangle order.
  std::vector<uint32_t> first;
  /// One per triangle.
  std::vector<NewestTriangle> entries;
  /// Per vertex: the smallest vertex of the last triangle (in triangle order) in which it is the
  /// middle one, else kNoVertexId; the predictor's neighbour for a vertex that is the newest of no
  /// triangle.
  std::vector<uint32_t> neighbour;
};

/// The decoded connectivity, and what the geometry stage predicts from.
struct DecodedConnectivity {
  /// 3 per triangle, decoded vertex ids 0..V-1.
  std::vector<uint32_t> indices;
  NewestTriangles newest;
  /// Version 8: the symbol section's last rANS state, where the geometry's starts.
  uint32_t last_state = kRansLow;
};

struct ConnectivityEncoding {
  /// The connectivity section (layout in docs/FORMAT.md) up to its symbol section, and its
  /// symbols, planned (set on success). The section is `prefix`, then `symbols->append_to()`:
  /// written last, once the geometry's first rANS state, where the chain ends, is known.
  std::vector<uint8_t> prefix;
  std::optional<SymbolEncoder> symbols;
  /// The triangles exactly as decode_connectivity will return them (same order, same corner
  /// rotation), in decoded vertex ids, and their newest triangles as it returns them.
  std::vector<uint32_t> decoded_indices;
  NewestTriangles decoded_newest;
  /// vertex_order[d] = the input vertex id of decoded vertex d. Decoded ids are 0..V-1.
  std::vector<uint32_t> vertex_order;
  /// The context models whose tables were planned to choose the smallest.
  uint32_t models_planned = 0;
};

/// Encodes `indices` (3 per triangle, every index < vertex_count, no triangle repeating an index,
/// every vertex referenced) losslessly: several components, boundaries, handles, non-manifold
/// edges and vertices and inconsistently oriented faces included. `search`: plan the tables of
/// every context model the encoder tries and keep the smallest; otherwise one model,
/// kFastContextModel.
Result<ConnectivityEncoding> encode_connectivity(const std::vector<uint32_t>& indices,
                                                 uint32_t vertex_count, bool search = true);

/// Decodes a connectivity section of stream `version` (1 to 8; its symbol section's layout
/// changed in version 8). `vertex_count` and `triangle_count` come from the stream's
/// header (already checked against the stream's size); the result has exactly triangle_count
/// triangles over exactly vertex_count vertices, numbered as the encoder's vertex_order says, and
/// `newest` is consistent with them (every vertex in it < vertex_count, or kNoVertexId where the
/// comments above allow).
/// Errors name `source` and the byte offset; hostile input never crashes, hangs or allocates
/// beyond O(vertex_count + triangle_count).
Result<DecodedConnectivity> decode_connectivity(ByteReader& in, uint32_t vertex_count,
                                                uint32_t triangle_count, uint8_t version,
                                                const std::string& source);

}  // namespace osteon::detail
