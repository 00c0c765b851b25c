// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>

#include "codec/code_placement.hpp"
#include "codec/entropy.hpp"

// How the codec codes a signed prediction residual: zigzag it, send the value itself below 4,
// else its bit length and the bit below the leading one as one entropy-coded symbol (residuals
// are Laplacian, so the lower half of each power-of-two bucket is likelier), then the remaining
// bits raw. Shared by the geometry and normal coders.

namespace osteon::detail {

/// Symbols a residual below 2^34 (zigzagged) can take.
constexpr uint32_t kResidualSymbols = 68;

inline uint64_t zigzag(int64_t r) {
  return (uint64_t(r) << 1) ^ uint64_t(r >> 63);
}
inline int64_t unzigzag(uint64_t z) {
  return int64_t(z >> 1) ^ -int64_t(z & 1);
}
inline uint32_t bit_length(uint64_t z) {
  return z == 0 ? 0 : 64 - uint32_t(__builtin_clzll(z));
}

/// The symbol of a zigzagged residual z < 2^34. Selects rather than branches: whether a residual
/// is below 4 is a coin toss the branch predictor loses.
inline uint32_t residual_symbol(uint64_t z) {
  const uint32_t b = bit_length(z | 1);  // >= 3 where it counts (z >= 4)
  const uint32_t large = 2 * b - 2 + uint32_t((z >> (b < 2 ? 0 : b - 2)) & 1);
  return z < 4 ? uint32_t(z) : large;
}

/// How many raw bits follow `symbol` for the zigzagged value z: bit length - 2, none below 4.
inline int residual_raw_bits(uint32_t symbol, uint64_t z) {
  return symbol < 4 ? 0 : int(bit_length(z)) - 2;
}

/// The raw bits that follow `symbol` for the zigzagged value z.
inline void put_residual_bits(SymbolEncoder& enc, uint32_t symbol, uint64_t z) {
  const int bits = residual_raw_bits(symbol, z);
  const uint64_t rest = z & ((uint64_t{1} << bits) - 1);
  if (bits > 32) [[unlikely]] {
    enc.put_bits(uint32_t(rest & 0xffffffffu), 32);
    enc.put_bits(uint32_t(rest >> 32), bits - 32);
  } else {
    enc.put_bits(uint32_t(rest), bits);
  }
}

/// The zigzagged value of `symbol` and its raw bits. Only the normals section reads residuals
/// this way (the geometry decoder reads its three axes' raw bits at once): compiled for size.
OSTEON_COLD_FUNCTION inline uint64_t get_residual(SymbolDecoder& dec, uint32_t symbol) {
  if (symbol < 4) return symbol;
  int bits = int(symbol - 4) / 2 + 1;  // bit length - 2
  uint64_t rest = bits > 32 ? (dec.get_bits(32) | (uint64_t{dec.get_bits(bits - 32)} << 32))
                            : dec.get_bits(bits);
  return ((uint64_t{2} | ((symbol - 4) & 1)) << bits) | rest;
}

}  // namespace osteon::detail
