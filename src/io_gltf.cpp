// SPDX-License-Identifier: Apache-2.0
// PLACEHOLDER: being written; replaced by the real reader.
#include "io_internal.hpp"

namespace osteon::detail {

Status parse_gltf(const uint8_t*, size_t, const std::string& source, const std::string&,
                  const ReadOptions&, Scene*) {
  return error(ErrorCode::kUnsupported, source, "gltf reader not written yet");
}

}  // namespace osteon::detail
