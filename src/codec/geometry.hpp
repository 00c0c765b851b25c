// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "codec/connectivity.hpp"
#include "core/byte_io.hpp"
#include "osteon/codec.hpp"
#include "osteon/mesh.hpp"
#include "osteon/status.hpp"

// The geometry stage of the codec (src/codec/quantize.cpp, src/codec/parallelogram.cpp): positions
// on a grid, predicted in vertex order from already-decoded neighbours, residuals entropy-coded.
// Both sides run on the same decoded connectivity (connectivity.hpp's NewestTriangles: each
// triangle filed under its newest vertex, with the vertex across from it), so the encoder needs
// nothing from the connectivity coder beyond what its decoder hands the geometry decoder, and the
// vertex order.

namespace osteon::detail {

/// Quantized coordinates, one int32 triple per vertex.
struct QuantizedPositions {
  std::vector<int32_t> xyz;  ///< 3 per vertex
};

/// std::llround(x) without the library call: x truncated toward zero, then moved one step where
/// the rest is half or more. Exact for |x| < 2^62: x - trunc(x) is exact in double.
inline int64_t round_half_away(double x) {
  const int64_t whole = static_cast<int64_t>(x);
  const double rest = x - static_cast<double>(whole);
  return whole + (rest >= 0.5 ? 1 : 0) - (rest <= -0.5 ? 1 : 0);
}

QuantizedPositions quantize(const std::vector<Vec3>& positions, const QuantizationGrid& grid);
std::vector<Vec3> dequantize(const QuantizedPositions& q, const QuantizationGrid& grid);

/// Encodes quantized positions (in decoded vertex order) given the decoded triangles' newest
/// triangles: vertices in id order are predicted by the average of all parallelograms available
/// across already-decoded triangles (the paper's eq. (1)), each placed by a triangle shape (its
/// offset shrunk, an equilateral apex blended in) where that pays, else by decoded neighbours
/// (a step out from the nearest), else by the previous vertex; the prediction follows its
/// neighbours' misses along the normal where that pays (curvature); residuals are entropy-coded.
/// `lattice` is the grid's QuantizationGrid::lattice (0: none); the encoder codes on that lattice
/// when its estimate says that is smaller. Appends the current version's geometry section
/// (docs/FORMAT.md) to `out`, its symbol section chained (SectionLayout) after the connectivity's
/// and before a section that starts at `end_state` (kRansLow where none follows). O(V + T).
/// Returns what it chose, as the section's first bytes say it (for EncodeReport), and its first
/// rANS state (the connectivity's end_state).
struct GeometryChoice {
  uint8_t mode = 0;  ///< the mode byte: prediction mode and the flags of the weights after it
  int shape_scale = 16;
  int shape_apex = 0;
  int extrapolation = 0;
  int curvature = 0;
  uint32_t first_state = 0;
  /// Vertices predicted by every coding measured and by the one kept (the search's work; the
  /// vertex count where the first coding measured is the one kept throughout).
  uint64_t predicted = 0;
};
GeometryChoice encode_geometry(const NewestTriangles& newest, const QuantizedPositions& q,
                               uint32_t lattice, std::vector<uint8_t>* out,
                               uint32_t end_state = kRansLow, bool search = true);
/// Decodes a geometry section of stream `version` (1 to 8; version 7's section is version 6's,
/// version 8's differs in its symbol section's layout alone),
/// for `vertex_count` vertices. `newest` is decode_connectivity's for the stream (its vertices <
/// vertex_count, each entry's n and p and each neighbour before the vertex it is filed under,
/// each o too or kNoVertexId). `chain`: in version 8, on entry the connectivity's last rANS
/// state, on return the geometry's (where the normals section starts, when `more` says one
/// follows). Errors name `source` and the byte offset. O(V + T); allocates O(V) beyond the result.
Result<QuantizedPositions> decode_geometry(ByteReader& in, const NewestTriangles& newest,
                                           uint32_t vertex_count, uint8_t version,
                                           const std::string& source, uint32_t* chain, bool more);

}  // namespace osteon::detail
