// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "byte_io.hpp"
#include "osteon/status.hpp"

// The connectivity stage of the codec (src/edgebreaker_encode.cpp, src/edgebreaker_decode.cpp,
// src/corner_table.*): any triangle list in, the same triangles out, vertices renumbered.

namespace osteon::detail {

struct ConnectivityEncoding {
  /// The connectivity section (layout in docs/FORMAT.md).
  std::vector<uint8_t> bytes;
  /// The triangles exactly as decode_connectivity will return them (same order, same corner
  /// rotation), in decoded vertex ids.
  std::vector<uint32_t> decoded_indices;
  /// vertex_order[d] = the input vertex id of decoded vertex d. Decoded ids are 0..V-1.
  std::vector<uint32_t> vertex_order;
};

/// Encodes `indices` (3 per triangle, every index < vertex_count, no triangle repeating an index,
/// every vertex referenced) losslessly: several components, boundaries, handles, non-manifold
/// edges and vertices and inconsistently oriented faces included.
Result<ConnectivityEncoding> encode_connectivity(const std::vector<uint32_t>& indices,
                                                 uint32_t vertex_count);

/// Decodes a connectivity section. `vertex_count` and `triangle_count` come from the stream's
/// header (already checked against the stream's size); the result has exactly triangle_count
/// triangles over exactly vertex_count vertices, numbered as the encoder's vertex_order says.
/// Errors name `source` and the byte offset; hostile input never crashes, hangs or allocates
/// beyond O(vertex_count + triangle_count).
Result<std::vector<uint32_t>> decode_connectivity(ByteReader& in, uint32_t vertex_count,
                                                  uint32_t triangle_count,
                                                  const std::string& source);

}  // namespace osteon::detail
