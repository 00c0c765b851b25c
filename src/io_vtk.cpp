// SPDX-License-Identifier: Apache-2.0
// PLACEHOLDER: being written; replaced by the real reader.
#include "io_internal.hpp"

namespace osteon::detail {

Status parse_vtk(const uint8_t*, size_t, const std::string& source, const ReadOptions&, Scene*) {
  return error(ErrorCode::kUnsupported, source, "vtk reader not written yet");
}

}  // namespace osteon::detail
