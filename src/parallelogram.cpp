// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "entropy.hpp"
#include "geometry.hpp"

// Based on: the parallelogram rule (Touma & Gotsman 1998) averaged over every parallelogram that
// is available when a vertex is decoded (Zhou, Jia & Su 2018, eq. (1): "three-parallelogram"
// prediction; Cohen-Or et al.'s multi-way prediction), with residuals coded as an Elias-gamma-like
// magnitude bucket (entropy-coded with context) plus raw mantissa bits (Draco and Corto code
// their residuals the same way).
//
//            o
//           / \          pred(v) = n + p - o for each decoded triangle (o, p, n) across the edge
//          /   \         (n, p) of a triangle (v, n, p) whose n and p are already decoded;
//         p-----n        the prediction is the rounded mean of all such parallelograms.
//          \   /
//           \ /
//            v

namespace osteon::detail {

namespace {

// How a vertex was predicted; the first part of the residual's coding context.
enum PredictionKind : uint32_t {
  kMultiParallelogram = 0,  // two or more parallelograms averaged
  kParallelogram = 1,       // exactly one
  kNeighbour = 2,           // an edge midpoint or a decoded neighbour
  kNone = 3,                // nothing decoded around it: the previous vertex, or the origin
  kKinds = 4,
};

// Residual symbols: z (zigzagged) itself below 4; above, its bit length b and the bit below the
// leading one (so each power-of-two bucket is split in halves: residuals are Laplacian, and the
// lower half of a bucket is more likely), then b - 2 raw bits. z < 2^34 gives symbols < 68.
constexpr uint32_t kSymbols = 68;

// Vertex -> corners (3 * triangle + k), in triangle order: compressed rows, built in O(n).
struct VertexCorners {
  std::vector<uint32_t> offsets;  // vertex_count + 1
  std::vector<uint32_t> corners;

  VertexCorners(const std::vector<uint32_t>& indices, uint32_t vertex_count)
      : offsets(size_t{vertex_count} + 1, 0), corners(indices.size()) {
    for (uint32_t v : indices) ++offsets[v + 1];
    for (uint32_t v = 0; v < vertex_count; ++v) offsets[v + 1] += offsets[v];
    std::vector<uint32_t> fill(offsets.begin(), offsets.end() - 1);
    for (uint32_t c = 0; c < indices.size(); ++c) corners[fill[indices[c]]++] = c;
  }
};

int64_t floor_div(int64_t a, int64_t b) {  // b > 0
  int64_t q = a / b;
  return (a % b != 0 && a < 0) ? q - 1 : q;
}

inline uint32_t next_corner(uint32_t c) {
  return c % 3 == 2 ? c - 2 : c + 1;
}
inline uint32_t prev_corner(uint32_t c) {
  return c % 3 == 0 ? c + 2 : c - 1;
}

// Which parallelograms a vertex uses. The encoder measures both on the mesh and keeps the
// cheaper: the mean of all of them wins on smooth surfaces (hip_mcs.ply: 12.9 against 14.1 bits
// per vertex), the first one on raw marching-cubes surfaces, whose coordinates sit on the voxel
// lattice that averaging smears (skull_mc.ply: 15.4 against 15.7).
enum PredictionMode : uint8_t {
  kAverageAll = 0,  // the paper's multi-parallelogram mean
  kFirstOnly = 1,   // the first parallelogram in corner order
  kModes = 2,
};

// The prediction of vertex v from the vertices before it; both sides call this with the same
// `q` for vertices < v, so encoder and decoder agree bit for bit.
PredictionKind predict(uint32_t v, const std::vector<uint32_t>& indices, const VertexCorners& vc,
                       const int32_t* q, PredictionMode mode, int64_t pred[3],
                       const uint8_t* activity, uint32_t* local_activity) {
  // The residual magnitude around v: the mean activity of its decoded neighbours.
  uint32_t act_sum = 0, act_count = 0;
  for (uint32_t i = vc.offsets[v]; i < vc.offsets[v + 1]; ++i) {
    uint32_t c = vc.corners[i];
    uint32_t n = indices[next_corner(c)];
    if (n < v) {
      act_sum += activity[n];
      ++act_count;
    }
  }
  *local_activity = act_count ? (2 * act_sum + act_count) / (2 * act_count) : 0;
  int64_t sum[3] = {0, 0, 0};
  int64_t count = 0;
  for (uint32_t i = vc.offsets[v]; i < vc.offsets[v + 1]; ++i) {
    uint32_t c = vc.corners[i];
    uint32_t n = indices[next_corner(c)], p = indices[prev_corner(c)];
    if (n >= v || p >= v) continue;
    // The triangle across edge (n, p) holds the half-edge p -> n: find it among p's corners.
    for (uint32_t j = vc.offsets[p]; j < vc.offsets[p + 1]; ++j) {
      uint32_t c2 = vc.corners[j];
      if (c2 / 3 == c / 3 || indices[next_corner(c2)] != n) continue;
      uint32_t o = indices[prev_corner(c2)];
      if (o >= v) continue;
      for (int k = 0; k < 3; ++k) {
        sum[k] += int64_t{q[3 * n + k]} + q[3 * p + k] - q[3 * o + k];
      }
      ++count;
      if (mode == kFirstOnly) break;
    }
    if (count > 0 && mode == kFirstOnly) break;
  }
  if (count > 0) {
    for (int k = 0; k < 3; ++k) pred[k] = floor_div(2 * sum[k] + count, 2 * count);
    return count > 1 ? kMultiParallelogram : kParallelogram;
  }
  // No parallelogram: the mean of the decoded edges' midpoints, else any decoded neighbour.
  uint32_t neighbour = UINT32_MAX;
  for (uint32_t i = vc.offsets[v]; i < vc.offsets[v + 1]; ++i) {
    uint32_t c = vc.corners[i];
    uint32_t n = indices[next_corner(c)], p = indices[prev_corner(c)];
    if (n < v && p < v) {
      for (int k = 0; k < 3; ++k) sum[k] += int64_t{q[3 * n + k]} + q[3 * p + k];
      count += 2;
    } else if (n < v) {
      neighbour = n;
    } else if (p < v) {
      neighbour = p;
    }
  }
  if (count > 0) {
    for (int k = 0; k < 3; ++k) pred[k] = floor_div(2 * sum[k] + count, 2 * count);
    return kNeighbour;
  }
  if (neighbour != UINT32_MAX) {
    for (int k = 0; k < 3; ++k) pred[k] = q[3 * neighbour + k];
    return kNeighbour;
  }
  for (int k = 0; k < 3; ++k) pred[k] = v > 0 ? q[3 * (v - 1) + k] : 0;
  return kNone;
}

// Context model: the prediction kind, the residual magnitude around the vertex (the mean of its
// decoded neighbours' largest residual symbols: surfaces are locally smooth or locally rough) and,
// for the second and third axis, the symbol just coded for the previous axis of the same vertex.
struct ContextModel {
  uint32_t activity_classes;
  uint32_t axis_classes;

  explicit ContextModel(uint32_t vertex_count)
      : activity_classes(vertex_count < 2000 ? 2 : (vertex_count < 50000 ? 6 : 10)),
        axis_classes(vertex_count < 2000 ? 1 : 4) {}

  uint32_t contexts() const { return kKinds * activity_classes * axis_classes; }
  uint32_t context(PredictionKind kind, uint32_t local_activity, int axis,
                   uint32_t previous_axis_symbol) const {
    uint32_t a = std::min(local_activity >> 1, activity_classes - 1);
    uint32_t b = axis == 0 ? 0 : std::min(1 + (previous_axis_symbol >> 2), axis_classes - 1);
    return (kind * activity_classes + a) * axis_classes + b;
  }
};

inline uint32_t bit_length(uint64_t z) {
  return z == 0 ? 0 : 64 - uint32_t(__builtin_clzll(z));
}

inline uint64_t zigzag(int64_t r) {
  return (uint64_t(r) << 1) ^ uint64_t(r >> 63);
}

inline uint32_t residual_symbol(uint64_t z) {
  if (z < 4) return uint32_t(z);
  uint32_t b = bit_length(z);  // >= 3
  return 4 + 2 * (b - 3) + uint32_t((z >> (b - 2)) & 1);
}

// Bits a symbol stream would cost under the context model, from its histogram (the table bytes
// are the same order of magnitude for both modes and left out).
double estimated_bits(const std::vector<uint32_t>& histogram, uint32_t contexts,
                      uint64_t raw_bits) {
  double bits = double(raw_bits);
  for (uint32_t c = 0; c < contexts; ++c) {
    const uint32_t* h = histogram.data() + size_t{c} * kSymbols;
    double total = 0;
    for (uint32_t s = 0; s < kSymbols; ++s) total += h[s];
    for (uint32_t s = 0; s < kSymbols; ++s) {
      if (h[s] != 0) bits += h[s] * std::log2(total / h[s]);
    }
  }
  return bits;
}

}  // namespace

void encode_geometry(const std::vector<uint32_t>& indices, const QuantizedPositions& q,
                     std::vector<uint8_t>* out) {
  uint32_t vertex_count = static_cast<uint32_t>(q.xyz.size() / 3);
  VertexCorners vc(indices, vertex_count);
  ContextModel model(vertex_count);

  // Measure both prediction modes, then code with the cheaper one.
  PredictionMode best = kAverageAll;
  double best_bits = 0;
  std::vector<uint8_t> activity(vertex_count, 0);
  for (uint32_t m = 0; m < kModes; ++m) {
    PredictionMode mode = PredictionMode(m);
    std::vector<uint32_t> histogram(size_t{model.contexts()} * kSymbols, 0);
    std::fill(activity.begin(), activity.end(), 0);
    uint64_t raw_bits = 0;
    for (uint32_t v = 0; v < vertex_count; ++v) {
      int64_t pred[3];
      uint32_t local = 0, symbol = 0, largest = 0;
      PredictionKind kind =
          predict(v, indices, vc, q.xyz.data(), mode, pred, activity.data(), &local);
      for (int k = 0; k < 3; ++k) {
        uint64_t z = zigzag(int64_t{q.xyz[3 * size_t{v} + k]} - pred[k]);
        uint32_t context = model.context(kind, local, k, symbol);
        symbol = residual_symbol(z);
        ++histogram[size_t{context} * kSymbols + symbol];
        if (symbol >= 4) raw_bits += bit_length(z) - 2;
        largest = std::max(largest, symbol);
      }
      activity[v] = uint8_t(largest);
    }
    double bits = estimated_bits(histogram, model.contexts(), raw_bits);
    if (m == 0 || bits < best_bits) {
      best = mode;
      best_bits = bits;
    }
  }

  out->push_back(best);
  SymbolEncoder enc(kSymbols, model.contexts());
  std::fill(activity.begin(), activity.end(), 0);
  for (uint32_t v = 0; v < vertex_count; ++v) {
    int64_t pred[3];
    uint32_t local = 0, symbol = 0, largest = 0;
    PredictionKind kind =
        predict(v, indices, vc, q.xyz.data(), best, pred, activity.data(), &local);
    for (int k = 0; k < 3; ++k) {
      uint64_t z = zigzag(int64_t{q.xyz[3 * size_t{v} + k]} - pred[k]);
      uint32_t context = model.context(kind, local, k, symbol);
      symbol = residual_symbol(z);
      enc.put(context, symbol);
      if (symbol >= 4) {
        int bits = int(bit_length(z)) - 2;
        uint64_t rest = z & ((uint64_t{1} << bits) - 1);
        if (bits > 32) {
          enc.put_bits(uint32_t(rest & 0xffffffffu), 32);
          enc.put_bits(uint32_t(rest >> 32), bits - 32);
        } else {
          enc.put_bits(uint32_t(rest), bits);
        }
      }
      largest = std::max(largest, symbol);
    }
    activity[v] = uint8_t(largest);
  }
  enc.append_to(out);
}

Result<QuantizedPositions> decode_geometry(ByteReader& in, const std::vector<uint32_t>& indices,
                                           uint32_t vertex_count, const std::string& source) {
  uint8_t mode = 0;
  if (!in.read_le(&mode) || mode >= kModes) {
    return error(ErrorCode::kInvalidData, source, "geometry: unknown prediction mode",
                 at_byte(in.offset()));
  }
  VertexCorners vc(indices, vertex_count);
  ContextModel model(vertex_count);
  SymbolDecoder dec;
  OSTEON_RETURN_IF_ERROR(dec.init(in, kSymbols, model.contexts(), source, "geometry"));
  QuantizedPositions q;
  q.xyz.resize(size_t{vertex_count} * 3);
  std::vector<uint8_t> activity(vertex_count, 0);
  for (uint32_t v = 0; v < vertex_count; ++v) {
    int64_t pred[3];
    uint32_t local = 0, symbol = 0, largest = 0;
    PredictionKind kind =
        predict(v, indices, vc, q.xyz.data(), PredictionMode(mode), pred, activity.data(), &local);
    for (int k = 0; k < 3; ++k) {
      symbol = dec.get(model.context(kind, local, k, symbol));
      uint64_t z = symbol;
      if (symbol >= 4) {
        int bits = int(symbol - 4) / 2 + 1;  // b - 2
        uint64_t rest = bits > 32 ? (dec.get_bits(32) | (uint64_t{dec.get_bits(bits - 32)} << 32))
                                  : dec.get_bits(bits);
        z = ((uint64_t{2} | ((symbol - 4) & 1)) << bits) | rest;
      }
      int64_t r = int64_t(z >> 1) ^ -int64_t(z & 1);
      int64_t value = pred[k] + r;
      if (!dec.ok() || value < INT32_MIN || value > INT32_MAX) {
        return error(ErrorCode::kInvalidData, source,
                     "geometry: corrupt residual for vertex " + std::to_string(v),
                     at_byte(in.offset()));
      }
      q.xyz[3 * size_t{v} + k] = static_cast<int32_t>(value);
      largest = std::max(largest, symbol);
    }
    activity[v] = uint8_t(largest);
  }
  OSTEON_RETURN_IF_ERROR(dec.finish(source, "geometry"));
  return q;
}

}  // namespace osteon::detail
