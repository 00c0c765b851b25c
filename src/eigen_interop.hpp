// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <Eigen/Dense>

#include "osteon/vec.hpp"

// What the rigid-fit code (src/pose.cpp, src/icp.cpp) shares to hand osteon's vectors to Eigen.

namespace osteon::detail {

using Matrix3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;

inline Eigen::Vector3d eig(const Vec3d& v) {
  return {v.x, v.y, v.z};
}

}  // namespace osteon::detail
