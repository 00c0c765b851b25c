// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "codec/geometry.hpp"
#include "core/byte_io.hpp"
#include "osteon/mesh.hpp"
#include "osteon/status.hpp"

// Transmitted normals (src/codec/normals.cpp): octahedral, predicted from the decoded surface.

namespace osteon::detail {

/// Appends the normals section: `normals` (one per vertex, decoded order) octahedrally quantized
/// to `bits` (8..16) per component, predicted by the area-weighted normal of the quantized
/// surface, residuals entropy-coded. Its symbol section is the stream's last, chained after the
/// geometry's (SectionLayout); returns its first rANS state (the geometry's end state).
uint32_t encode_normals(const std::vector<uint32_t>& indices, const QuantizedPositions& q,
                        const std::vector<Vec3>& normals, int bits, std::vector<uint8_t>* out);
/// Decodes the normals section of stream `version` for the decoded triangles and quantized
/// positions; `first_state` is the geometry's last rANS state (version 8).
Result<std::vector<Vec3>> decode_normals(ByteReader& in, const std::vector<uint32_t>& indices,
                                         const QuantizedPositions& q, uint8_t version,
                                         const std::string& source, uint32_t first_state);
/// The unit vector an octahedral code (u, v), each in [0, 2^bits - 1], stands for.
Vec3 octahedral_decode(uint32_t u, uint32_t v, int bits);

}  // namespace osteon::detail
