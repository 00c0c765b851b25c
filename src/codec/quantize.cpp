// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <utility>
#include <vector>

#include "codec/geometry.hpp"

// Based on: uniform scalar quantization of positions on a grid fitted to the bounding box (Deering
// 1995; Draco's and meshoptimizer's position quantization), with the step set either by a bit count
// or by an absolute error bound, the way a clinician states tolerance ("0.05 mm").

namespace osteon {

namespace {
constexpr double kMaxCells = double(1 << 30);  // a side of the grid fits int32 with room for deltas

// Lattice detection: the most frequent coordinate values of a sample, per axis, fitted by
// v0 + i * spacing; a lattice when the three spacings agree and most vertices have two
// coordinates on their planes.
constexpr size_t kLatticeProbe = 4096;
constexpr size_t kLatticeSample = 65536;
constexpr size_t kLatticeTopValues = 64;
constexpr double kLatticeTolerance = 0.02;  // of the spacing, for "on a plane"
constexpr uint32_t kMaxLattice = uint32_t{1} << 24;

float& coordinate(Vec3& p, int axis) {
  return axis == 0 ? p.x : (axis == 1 ? p.y : p.z);
}
float coordinate(const Vec3& p, int axis) {
  return axis == 0 ? p.x : (axis == 1 ? p.y : p.z);
}

struct AxisLattice {
  double v0 = 0, spacing = 0;
};

/// The lattice planes along one axis, from the sample's most frequent values; false when the
/// values do not repeat or their gaps are not above two steps.
bool fit_axis(std::vector<float> values, double step, AxisLattice* out) {
  std::sort(values.begin(), values.end());
  std::vector<std::pair<uint32_t, float>> runs;  // (count, value)
  for (size_t i = 0; i < values.size();) {
    size_t j = i;
    while (j < values.size() && values[j] == values[i]) ++j;
    runs.push_back({uint32_t(j - i), values[i]});
    i = j;
  }
  size_t top = std::min(kLatticeTopValues, runs.size());
  if (top < 4) return false;
  std::partial_sort(runs.begin(), runs.begin() + top, runs.end(), [](const auto& a, const auto& b) {
    return a.first > b.first || (a.first == b.first && a.second < b.second);
  });
  // Planes: values that repeat, and at least a sixteenth as often as the most frequent one.
  const uint32_t least = std::max<uint32_t>(2, runs[0].first / 16);
  while (top > 0 && runs[top - 1].first < least) --top;
  if (top < 4) return false;
  std::vector<double> planes(top);
  for (size_t i = 0; i < top; ++i) planes[i] = runs[i].second;
  std::vector<double> sorted = planes;
  std::sort(sorted.begin(), sorted.end());
  double gap = sorted[1] - sorted[0];
  for (size_t i = 1; i + 1 < top; ++i) gap = std::min(gap, sorted[i + 1] - sorted[i]);
  if (!(gap >= 2 * step)) return false;
  // Least squares over the planes' indices, from the most frequent plane.
  double si = 0, sv = 0, sii = 0, siv = 0;
  for (double v : planes) {
    const double i = std::round((v - planes[0]) / gap);
    si += i;
    sv += v;
    sii += i * i;
    siv += i * v;
  }
  const double n = double(top);
  const double spread = sii - si * si / n;
  out->spacing = spread > 0 ? (siv - si * sv / n) / spread : gap;
  out->v0 = (sv - out->spacing * si) / n;
  if (!(out->spacing >= 2 * step)) return false;
  for (double v : planes) {  // every plane on the fitted lattice
    const double t = (v - out->v0) / out->spacing;
    if (std::fabs(t - std::round(t)) >= kLatticeTolerance) return false;
  }
  return true;
}

/// Moves `grid` onto the positions' voxel lattice, if they sit on one (see choose_grid).
void fit_lattice(const std::vector<Vec3>& positions, Vec3 lo, QuantizationGrid* grid) {
  {
    // Cheap rejection first: on a lattice, most x coordinates repeat another's exactly (a plane
    // holds many vertices); elsewhere few do.
    // Counted in an open-addressing set of the values' bits (a sort of the probe took 3% of a
    // 10,000-triangle encode): repeats = probed - distinct.
    const size_t stride = std::max<size_t>(1, positions.size() / kLatticeProbe);
    const size_t values = (positions.size() + stride - 1) / stride;  // < 2 * kLatticeProbe
    constexpr uint32_t kEmpty = 0xFFFFFFFFu;  // a NaN's bits: never a probed value
    int set_bits = 4;                         // at least twice as many slots as values
    while ((size_t{1} << set_bits) < 2 * values) ++set_bits;
    std::vector<uint32_t> set(size_t{1} << set_bits, kEmpty);
    const uint32_t slot_mask = (1u << set_bits) - 1;
    size_t probed = 0, repeats = 0;
    for (size_t i = 0; i < positions.size(); i += stride, ++probed) {
      const float x = positions[i].x + 0.0f;  // -0 as +0, which compares equal to it
      if (std::isnan(x)) continue;            // equal to nothing
      uint32_t key = 0;
      std::memcpy(&key, &x, sizeof key);
      uint32_t slot = (key * 0x9E3779B1u) >> (32 - set_bits);
      while (set[slot] != kEmpty && set[slot] != key) slot = (slot + 1) & slot_mask;
      repeats += set[slot] == key ? 1 : 0;
      set[slot] = key;
    }
    if (repeats * 8 < probed) return;
  }
  const size_t stride = std::max<size_t>(1, positions.size() / kLatticeSample);
  std::vector<Vec3> sample;
  for (size_t i = 0; i < positions.size(); i += stride) sample.push_back(positions[i]);
  AxisLattice axis[3];
  for (int a = 0; a < 3; ++a) {
    std::vector<float> values(sample.size());
    for (size_t i = 0; i < sample.size(); ++i) values[i] = coordinate(sample[i], a);
    if (!fit_axis(std::move(values), grid->step, &axis[a])) return;
  }
  const double spacing = (axis[0].spacing + axis[1].spacing + axis[2].spacing) / 3;
  for (const AxisLattice& l : axis) {
    if (std::fabs(l.spacing - spacing) > 1e-4 * spacing) return;  // anisotropic voxels
  }
  size_t on_two_planes = 0;
  for (const Vec3& p : sample) {
    int on = 0;
    for (int a = 0; a < 3; ++a) {
      const double t = (coordinate(p, a) - axis[a].v0) / spacing;
      on += std::fabs(t - std::round(t)) < kLatticeTolerance ? 1 : 0;
    }
    on_two_planes += on >= 2 ? 1 : 0;
  }
  if (double(on_two_planes) < 0.9 * double(sample.size())) return;
  const double k = std::ceil(spacing / grid->step - 1e-9);
  if (k < 2 || k > kMaxLattice) return;
  grid->step = spacing / k;
  grid->lattice = uint32_t(k);
  for (int a = 0; a < 3; ++a) {
    coordinate(grid->origin, a) = static_cast<float>(
        axis[a].v0 - std::ceil((axis[a].v0 - coordinate(lo, a)) / spacing) * spacing);
  }
}

/// The largest float at most `step` (or `step` itself where no positive float is): a step that is
/// a float takes 4 bytes of a stream's header instead of 8 (docs/FORMAT.md), and a step no larger
/// keeps every error bound the step was chosen for.
double float_step(double step) {
  if (!(step <= std::numeric_limits<float>::max())) return step;  // and NaN: the caller refuses it
  float f = static_cast<float>(step);
  if (double(f) > step) f = std::nextafter(f, 0.0f);
  return f > 0 ? double(f) : step;
}

}  // namespace

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
  } else {
    // The codec's own step, from the precision or the bits; on a lattice where the positions sit
    // on one, else rounded down to a float.
    if (options.precision == 0 && (options.bits < 8 || options.bits > 24)) {
      return error(ErrorCode::kInvalidArgument, "",
                   "--bits must be between 8 and 24, not " + std::to_string(options.bits));
    }
    grid.origin = lo;
    grid.step = options.precision > 0 ? 2.0 * options.precision
                : side > 0            ? side / double((uint32_t{1} << options.bits) - 1)
                                      : 1.0;
    if (options.precision > 0 || side > 0) fit_lattice(positions, lo, &grid);
    if (grid.lattice == 0) grid.step = float_step(grid.step);
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
      q.xyz[3 * i + k] =
          static_cast<int32_t>(round_half_away((double(p[k]) - origin[k]) / grid.step));
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
