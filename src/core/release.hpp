// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <vector>

namespace osteon::detail {

/// Frees a vector's storage now, so that a pass can hand its memory to the next one. (`v = {}`
/// does not: it picks the initializer-list assignment, which empties the vector but keeps the
/// capacity.)
template <class T>
void release(std::vector<T>& v) {
  std::vector<T>().swap(v);
}

}  // namespace osteon::detail
