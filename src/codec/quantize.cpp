// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <cmath>

#include "codec/geometry.hpp"

// Based on: uniform scalar quantization of positions on a grid fitted to the bounding box (Deering
// 1995; Draco's and meshoptimizer's position quantization), with the step set either by a bit count
// or by an absolute error bound, the way a clinician states tolerance ("0.05 mm").

namespace osteon {

namespace {
constexpr double kMaxCells = double(1 << 30);  // a side of the grid fits int32 with room for deltas
}

Result<QuantizationGrid> choose_grid(const std::vector<Vec3>& positions,
                                     const EncodeOptions& options) {
  QuantizationGrid grid;
  if (positions.empty()) {
    grid.step = options.grid.step > 0 ? options.grid.step : 1.0;
    grid.origin = options.grid.origin;
    return grid;
  }
  Vec3 lo = positions[0], hi = positions[0];
  for (const Vec3& p : positions) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  double side = std::max({double(hi.x) - lo.x, double(hi.y) - lo.y, double(hi.z) - lo.z});
  if (options.grid.step > 0) {
    if (!std::isfinite(options.grid.step)) {
      return error(ErrorCode::kInvalidArgument, "", "the shared grid's step is not finite");
    }
    grid = options.grid;
  } else if (options.precision < 0 || !std::isfinite(options.precision)) {
    return error(ErrorCode::kInvalidArgument, "", "--precision must be a positive number");
  } else if (options.precision > 0) {
    grid.origin = lo;
    grid.step = 2.0 * options.precision;
  } else {
    if (options.bits < 8 || options.bits > 24) {
      return error(ErrorCode::kInvalidArgument, "",
                   "--bits must be between 8 and 24, not " + std::to_string(options.bits));
    }
    grid.origin = lo;
    grid.step = side > 0 ? side / double((uint32_t{1} << options.bits) - 1) : 1.0;
  }
  // Every quantized coordinate must stay within +-2^30 so that residuals fit 32 bits.
  double reach =
      std::max({std::fabs(double(lo.x) - grid.origin.x), std::fabs(double(lo.y) - grid.origin.y),
                std::fabs(double(lo.z) - grid.origin.z), std::fabs(double(hi.x) - grid.origin.x),
                std::fabs(double(hi.y) - grid.origin.y), std::fabs(double(hi.z) - grid.origin.z)});
  if (reach / grid.step >= kMaxCells) {
    return error(ErrorCode::kInvalidArgument, "",
                 "the grid is too fine for this mesh: " + std::to_string(reach / grid.step) +
                     " cells from the origin, at most 2^30 (use a larger --precision or fewer "
                     "--bits)");
  }
  return grid;
}

namespace detail {

QuantizedPositions quantize(const std::vector<Vec3>& positions, const QuantizationGrid& grid) {
  QuantizedPositions q;
  q.xyz.resize(positions.size() * 3);
  const double origin[3] = {grid.origin.x, grid.origin.y, grid.origin.z};
  for (size_t i = 0; i < positions.size(); ++i) {
    const float p[3] = {positions[i].x, positions[i].y, positions[i].z};
    for (int k = 0; k < 3; ++k) {
      q.xyz[3 * i + k] = static_cast<int32_t>(std::llround((double(p[k]) - origin[k]) / grid.step));
    }
  }
  return q;
}

std::vector<Vec3> dequantize(const QuantizedPositions& q, const QuantizationGrid& grid) {
  std::vector<Vec3> out(q.xyz.size() / 3);
  for (size_t i = 0; i < out.size(); ++i) {
    out[i] = {static_cast<float>(grid.origin.x + double(q.xyz[3 * i]) * grid.step),
              static_cast<float>(grid.origin.y + double(q.xyz[3 * i + 1]) * grid.step),
              static_cast<float>(grid.origin.z + double(q.xyz[3 * i + 2]) * grid.step)};
  }
  return out;
}

}  // namespace detail
}  // namespace osteon
