// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>
#include <cstring>
#include <vector>

#include "osteon/mesh.hpp"

// The exact-equality vertex welder, shared by weld() and the streaming STL reader, which welds a
// triangle soup as it arrives so the soup is never held in memory.

namespace osteon::detail {

/// Open-addressing hash set of vertex ids keyed by their position's bits (-0 and +0 are equal).
/// Positions live in the caller's vector; the table holds indices into it.
class ExactWelder {
 public:
  /// `positions` must outlive the welder; `expected` sizes the table (it grows as needed).
  ExactWelder(std::vector<Vec3>* positions, size_t expected);

  /// The id of `p`: an existing vertex with bitwise-equal (after -0 -> +0) coordinates, or a new
  /// one appended to the positions.
  uint32_t insert(Vec3 p) {
    canonicalize(p);
    if ((positions_->size() + 1) * 2 > table_.size()) grow();
    uint64_t mask = table_.size() - 1;
    uint64_t slot = hash(p) & mask;
    while (true) {
      uint32_t id = table_[slot];
      if (id == kEmpty) break;
      if (bits_equal((*positions_)[id], p)) return id;
      slot = (slot + 1) & mask;
    }
    uint32_t id = static_cast<uint32_t>(positions_->size());
    positions_->push_back(p);
    table_[slot] = id;
    return id;
  }

  static void canonicalize(Vec3& p) {
    // Adding +0.0f turns -0.0f into +0.0f and changes nothing else (NaN is rejected earlier).
    p.x += 0.0f;
    p.y += 0.0f;
    p.z += 0.0f;
  }

 private:
  static constexpr uint32_t kEmpty = 0xffffffffu;

  static uint64_t hash(const Vec3& p) {
    uint32_t b[3];
    std::memcpy(b, &p, sizeof(b));
    uint64_t h = (uint64_t{b[0]} * 0x9E3779B97F4A7C15ull) ^
                 (uint64_t{b[1]} * 0xC2B2AE3D27D4EB4Full) ^
                 (uint64_t{b[2]} * 0x165667B19E3779F9ull);
    return h ^ (h >> 29);
  }
  static bool bits_equal(const Vec3& a, const Vec3& b) {
    return std::memcmp(&a, &b, sizeof(Vec3)) == 0;
  }
  void grow();

  std::vector<Vec3>* positions_;
  std::vector<uint32_t> table_;
};

}  // namespace osteon::detail
