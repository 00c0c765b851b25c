// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "codec/code_placement.hpp"

// What the codec's container encoder (src/codec/codec_encode.cpp) and decoder
// (src/codec/codec_decode.cpp) share: the header's constants and the checksum. docs/FORMAT.md
// specifies every byte.

namespace osteon::detail {

constexpr uint8_t kStreamMagic[4] = {'O', 'S', 'T', 'M'};
/// The version the encoder writes; the decoder reads kOldestStreamVersion..kStreamVersion
/// (version 2 added lattice coding to the geometry section, version 3 tangent-plane prediction;
/// version 7 the compact header, version 8 compact symbol sections and a float step).
constexpr uint8_t kStreamVersion = 8;  // osteon::kStreamVersion (codec_encode.cpp checks)
constexpr uint8_t kOldestStreamVersion = 1;
/// Up to version 6 the header has fixed fields (60 bytes); from version 7, varint counts and
/// lengths and a float origin: at least 29 bytes, 25 where version 8 stores the step as a float.
constexpr uint8_t kCompactHeaderVersion = 7;
constexpr size_t kCompactHeaderBytes = 4 + 1 + 1 + 1 + 1 + 3 * 4 + 4 + 1;
/// Header flags: a normals section follows the geometry; (version 8) the step is stored as an
/// f32, which it equals exactly.
constexpr uint8_t kFlagNormals = 1;
constexpr uint8_t kFlagFloatStep = 2;
/// Whether `value` is exactly a float (a step the header can store in 4 bytes; out of a float's
/// range the conversion itself would be undefined).
inline bool is_float(double value) {
  return std::fabs(value) <= std::numeric_limits<float>::max() && double(float(value)) == value;
}
constexpr size_t kStreamChecksumBytes = 4;
/// A stream may describe at most this many triangles per byte of its own size: far above what
/// any real mesh reaches (a few bits per triangle), and it bounds what hostile bytes can allocate.
constexpr uint64_t kMaxTrianglesPerByte = 1024;
constexpr uint32_t kMaxTriangles = uint32_t{1} << 28;

/// CRC-32's byte table, computed on first use: 256 entries of loop rather than 1 KB of
/// incompressible constants in the WebAssembly decoder's download.
OSTEON_NOINLINE inline std::array<uint32_t, 256> make_crc32_table() {
  std::array<uint32_t, 256> t{};
  for (uint32_t i = 0; i < 256; ++i) {
    uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    t[i] = c;
  }
  return t;
}

/// CRC-32 (IEEE 802.3, reflected, polynomial 0xEDB88320).
inline uint32_t crc32(const uint8_t* data, size_t size) {
  static const std::array<uint32_t, 256> table = make_crc32_table();
  uint32_t crc = 0xffffffffu;
  for (size_t i = 0; i < size; ++i) crc = table[(crc ^ data[i]) & 0xff] ^ (crc >> 8);
  return crc ^ 0xffffffffu;
}

}  // namespace osteon::detail
