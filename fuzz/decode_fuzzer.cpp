// SPDX-License-Identifier: Apache-2.0
// libFuzzer target for the mesh codec's decoder: any bytes in, a clear error or a valid mesh out.
// The checksum would stop almost every mutation at the door, so the fuzzer recomputes it first
// (half the time) to reach the section decoders behind it.
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "codec/codec_internal.hpp"
#include "osteon/codec.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<uint8_t> bytes(data, data + size);
  if (size > osteon::detail::kStreamChecksumBytes && (size & 1) == 0) {
    uint32_t crc = osteon::detail::crc32(bytes.data(), size - 4);
    std::memcpy(bytes.data() + size - 4, &crc, 4);
  }
  osteon::Result<osteon::Mesh> mesh = osteon::decode(bytes.data(), bytes.size(), "fuzz.ostm");
  if (!mesh.ok()) {
    if (mesh.status().message().rfind("fuzz.ostm: ", 0) != 0) std::abort();
    return 0;
  }
  for (uint32_t index : mesh->indices) {
    if (index >= mesh->positions.size()) std::abort();
  }
  if (mesh->indices.size() % 3 != 0) std::abort();
  return 0;
}
