// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <vector>

#include "codec/connectivity.hpp"
#include "codec/entropy.hpp"
#include "codec/geometry.hpp"
#include "codec/residual.hpp"
#include "core/byte_io.hpp"

// Based on: the parallelogram rule (Touma & Gotsman 1998) averaged over every parallelogram that
// is available when a vertex is decoded (Zhou, Jia & Su 2018, eq. (1): "three-parallelogram"
// prediction; Cohen-Or et al.'s multi-way prediction), with residuals coded as an Elias-gamma-like
// magnitude bucket (entropy-coded with context) plus raw mantissa bits (Draco and Corto code
// their residuals the same way).
//
//            o
//           / \          pred(v) = n + p - o for each triangle (v, n, p) whose other two
//          /   \         vertices come before v (v is its newest vertex), with o the vertex
//         p-----n        across the edge (n, p) in the neighbouring triangle, when o comes
//          \   /         before v too; the prediction is the rounded mean of all such
//           \ /          parallelograms.
//            v
//
// Lattice coding (stream version 2; Lorensen & Cline 1987 for where marching-cubes vertices lie):
// a raw marching-cubes vertex sits on a lattice edge, so two of its three coordinates are on
// lattice planes (multiples of the grid's lattice period L once choose_grid has aligned the grid)
// and only the third, along the edge, is free. Each vertex then codes which axes are on planes
// (a 3-bit mask, in the context of the axis its prediction's normal points along most: the edge
// the surface crosses tends to be that axis) and, per axis, either the plane index's residual
// from the plane nearest the prediction, in units of L, or the free coordinate's residual.
//
// Tangent-plane prediction (stream version 3): on irregular triangles the parallelogram misses
// mostly along the surface. The axis the normal of the vertex's parallelograms points along most
// is then predicted on the plane through the prediction with that normal, from the other two
// axes' residuals (on_tangent_plane), and its residual codes in contexts of its own.
//
// The apex weight (stream version 4): each parallelogram may be blended, in eighths, with the
// apex of the equilateral triangle on its edge (n, p), in the plane of (n, p, o), away from o
// (blend_apex). A parallelogram copies the shape of o's triangle; where triangles scatter around
// equilateral (smoothed isosurfaces, raw marching cubes), the apex misses by less. The encoder
// chooses the weight per mesh (choose_apex).
//
// Speed: every triangle has exactly one newest vertex, so grouping each triangle (n, p, o) under
// its newest vertex (NewestTriangles, which the connectivity decoder builds as it writes the
// triangles) gives every vertex its parallelograms in one contiguous run: the decoding loop reads
// about two 12-byte entries a vertex, with no search and no walk around the vertex.

namespace osteon::detail {

namespace {

// How a vertex was predicted; the first part of the residual's coding context.
enum PredictionKind : uint32_t {
  kMultiParallelogram = 0,  // two or more parallelograms averaged
  kParallelogram = 1,       // exactly one
  kNeighbour = 2,           // edge midpoints, or a decoded neighbour
  kNone = 3,                // nothing decoded around it: the previous vertex, or the origin
  kKinds = 4,
};

// Which parallelograms a vertex uses. The encoder measures both on the mesh and keeps the
// cheaper: the mean of all of them wins on smooth surfaces (hip_mcs.ply at 14 bits: 12.6 against
// 13.7 bits per vertex), the first one on raw marching-cubes surfaces, whose coordinates sit on
// the voxel lattice that averaging smears (skull_mc.ply: 15.1 against 15.4).
enum PredictionMode : uint8_t {
  kAverageAll = 0,  // the paper's multi-parallelogram mean
  kFirstOnly = 1,   // the first parallelogram in triangle order
  kModes = 2,
};

/// The rounded mean sum / count: floor((2 * sum + count) / (2 * count)), for 1 <= count < 2^29
/// and |sum| < 2^33 * count (count parallelograms of int32 coordinates). One unsigned division,
/// no fix-up: adding 2^34 * (2 * count) makes the dividend positive (and < 2^64), so the
/// division truncates to the floor, 2^34 too high.
inline int64_t rounded_mean(int64_t sum, int64_t count) {
  constexpr int kBiasBits = 34;
  const uint64_t divisor = 2 * static_cast<uint64_t>(count);
  const uint64_t dividend = static_cast<uint64_t>(2 * sum + count) + (divisor << kBiasBits);
  return static_cast<int64_t>(dividend / divisor) - (int64_t{1} << kBiasBits);
}

/// floor(x / d) for 2 <= d <= kMaxSmallDivisor and x <= kMaxSmallDividend by a multiply and a
/// shift (the neighbours' mean symbol sits on the entropy decoder's critical path, where a
/// division's latency shows); kReciprocal[d] = ceil(2^16 / d) is exact there (checked below).
constexpr uint32_t kMaxSmallDivisor = 16;
constexpr uint32_t kMaxSmallDividend = 8 * 2 * 127 + 8;  // 8 triangles' symbol sums, rounded
constexpr auto kReciprocal = [] {
  std::array<uint32_t, kMaxSmallDivisor + 1> r{};
  for (uint32_t d = 1; d <= kMaxSmallDivisor; ++d) r[d] = ((1u << 16) + d - 1) / d;
  return r;
}();
constexpr bool reciprocals_are_exact() {
  for (uint32_t d = 2; d <= kMaxSmallDivisor; ++d) {
    for (uint32_t x = 0; x <= kMaxSmallDividend; ++x) {
      if ((x * kReciprocal[d]) >> 16 != x / d) return false;
    }
  }
  return true;
}
static_assert(reciprocals_are_exact());

/// Per residual symbol (residual.hpp): how many raw bits follow it, and the zigzagged value's
/// bits above them (the value itself below 4), so that value = leading | raw bits.
constexpr auto kRawBits = [] {
  std::array<uint8_t, kResidualSymbols> bits{};
  for (uint32_t s = 4; s < kResidualSymbols; ++s) bits[s] = static_cast<uint8_t>((s - 4) / 2 + 1);
  return bits;
}();
constexpr auto kLeadingBits = [] {
  std::array<uint64_t, kResidualSymbols> lead{};
  for (uint32_t s = 0; s < kResidualSymbols; ++s) {
    lead[s] = s < 4 ? s : (uint64_t{2} | ((s - 4) & 1)) << kRawBits[s];
  }
  return lead;
}();

/// A decoded vertex's three residual symbols (each < 128) packed in 11-bit lanes, so that adding
/// up to 16 vertices' symbols adds each axis in its own lane.
constexpr int kLaneBits = 11;
constexpr uint32_t kLaneMask = (1u << kLaneBits) - 1;
inline uint32_t pack_symbols(uint32_t s0, uint32_t s1, uint32_t s2) {
  return s0 | s1 << kLaneBits | s2 << (2 * kLaneBits);
}
inline uint32_t lane(uint64_t lanes, int axis) {
  return static_cast<uint32_t>(lanes >> (kLaneBits * axis)) & kLaneMask;
}

struct Prediction {
  PredictionKind kind;
  uint32_t local[3];  // per axis: the residual magnitude around the vertex, for the context
  int64_t xyz[3];
};

/// Per axis, the rounded mean of the symbols of the 2 * entries neighbours of v's entries
/// [begin, end), given `lanes`, their packed symbols summed (Prediction::local).
inline void mean_symbols(const NewestTriangle* begin, const NewestTriangle* end, uint64_t lanes,
                         const uint32_t* symbols, uint32_t local[3]) {
  const uint32_t entries = static_cast<uint32_t>(end - begin);
  if (entries <= kMaxSmallDivisor / 2) [[likely]] {
    for (int k = 0; k < 3; ++k) {
      local[k] = ((lane(lanes, k) + entries) * kReciprocal[2 * entries]) >> 16;
    }
  } else {
    // Lanes may overflow into each other beyond 16 entries: add them up again, apart.
    uint32_t sums[3] = {0, 0, 0};
    for (const NewestTriangle* f = begin; f != end; ++f) {
      for (int k = 0; k < 3; ++k) sums[k] += lane(symbols[f->n], k) + lane(symbols[f->p], k);
    }
    for (int k = 0; k < 3; ++k) local[k] = (sums[k] + entries) / (2 * entries);
  }
}

/// |x| of a 64-bit two's-complement value, as unsigned (0 - x for a negative one).
inline uint64_t magnitude(uint64_t x) {
  return x >> 63 ? 0 - x : x;
}

/// floor(sqrt(x)) for 0 <= x < 2^62, exactly: the floating-point root is within one of it (x
/// rounds to 53 bits, the root to 52), and one step each way corrects it, so the result is the
/// same wherever the root rounds differently. Signed conversions: WebAssembly's unsigned ones
/// take several instructions.
inline int64_t isqrt(int64_t x) {
  int64_t r = static_cast<int64_t>(std::sqrt(static_cast<double>(x)));
  r -= r * r > x ? 1 : 0;
  r += (r + 1) * (r + 1) <= x ? 1 : 0;
  return r;
}

/// The apex prediction's weight is in eighths (stream version 4): kApexWeights values, 0 to 8,
/// in the geometry mode byte's bits from kApexShift up (below them, the prediction mode).
constexpr uint32_t kApexWeights = 9;
constexpr int kApexShift = 2;
/// floor(sqrt(3) 2^45), the apex's height over its edge in fixed point.
constexpr int64_t kRootThree = 60941120090265;

/// One parallelogram's prediction for stream version 4, with the apex weight a (1 to 8, in
/// eighths): (8 - a) eighths of the parallelogram n + p - o, and a eighths of the apex of the
/// equilateral triangle on the edge (n, p), in the plane of (n, p, o) on the side away from o.
/// Regular meshes (smoothed isosurfaces) have near-equilateral triangles, where the apex misses
/// less than copying o's triangle. In integers, so that every platform predicts the same:
///   e = p - n, t = n + p - 2o, both shifted right by s until every component fits 15 bits;
///   c = t x e, the triangle's normal, scaled so that its largest component has 30 bits;
///   2d = floor(((e x c) floor(kRootThree / isqrt(c.c)) + 2^44) / 2^45) 2^s: twice the apex's
///   offset from the edge's midpoint, sqrt(3) |e| across the edge, in the triangle's plane;
///   value = floor(((8 - a) 2 (n + p - o) + a (n + p + 2d) + 8) / 16), clamped to +-(2^33 - 1).
/// Without a triangle (c zero: o on the line through n and p) the apex is the edge's midpoint.
inline void blend_apex(const int32_t* n, const int32_t* p, const int32_t* o, uint32_t apex,
                       int64_t value[3]) {
  int64_t e[3], t[3];
  uint64_t big = 0;
  for (int k = 0; k < 3; ++k) {
    e[k] = int64_t{p[k]} - n[k];
    t[k] = int64_t{n[k]} + p[k] - 2 * int64_t{o[k]};
    big |= magnitude(uint64_t(e[k])) | magnitude(uint64_t(t[k]));
  }
  const int s = std::max(0, static_cast<int>(std::bit_width(big)) - 15);
  for (int k = 0; k < 3; ++k) {
    e[k] >>= s;
    t[k] >>= s;
  }
  int64_t c[3] = {t[1] * e[2] - t[2] * e[1], t[2] * e[0] - t[0] * e[2], t[0] * e[1] - t[1] * e[0]};
  const int width = static_cast<int>(std::bit_width(
      magnitude(uint64_t(c[0])) | magnitude(uint64_t(c[1])) | magnitude(uint64_t(c[2]))));
  for (int64_t& ck : c) ck = width > 30 ? ck >> (width - 30) : ck * (int64_t{1} << (30 - width));
  const int64_t ratio =
      kRootThree / std::max<int64_t>(isqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]), 1);
  const int64_t across[3] = {e[1] * c[2] - e[2] * c[1], e[2] * c[0] - e[0] * c[2],
                             e[0] * c[1] - e[1] * c[0]};
  constexpr int64_t kLimit = (int64_t{1} << 33) - 1;
  for (int k = 0; k < 3; ++k) {
    const int64_t np = int64_t{n[k]} + p[k];
    const int64_t apex2 = np + ((across[k] * ratio + (int64_t{1} << 44)) >> 45) * (int64_t{1} << s);
    const int64_t blended = ((8 - int64_t{apex}) * 2 * (np - o[k]) + apex * apex2 + 8) >> 4;
    value[k] = std::clamp(blended, -kLimit, kLimit);
  }
}

// The prediction of vertex v from the vertices before it; the encoder and the decoder call this
// with the same records for vertices < v, so they agree bit for bit. kTwoCodings (the encoder
// measuring two codings of the same prediction at once): also the local activity of a second
// coding's symbols, into other_local. apex: the apex prediction's weight in eighths (0: the
// parallelogram alone).
template <bool kTwoCodings = false>
inline Prediction predict(uint32_t v, const NewestTriangles& nt, const int32_t* xyz,
                          const uint32_t* symbols, PredictionMode mode, uint32_t apex,
                          const uint32_t* other_symbols = nullptr,
                          uint32_t* other_local = nullptr) {
  Prediction out;
  const NewestTriangle* e = nt.entries.data() + nt.first[v];
  const NewestTriangle* const end = nt.entries.data() + nt.first[v + 1];
  if (e == end) [[unlikely]] {
    // No triangle whose other vertices are all decoded: a decoded neighbour, else the previous
    // vertex (often a neighbour too: vertices are numbered along the decoded faces).
    const uint32_t u = nt.neighbour[v];
    out.kind = u != kNoVertexId ? kNeighbour : kNone;
    const uint32_t w = u != kNoVertexId ? u : v - 1;
    for (int k = 0; k < 3; ++k) {
      out.local[k] = u != kNoVertexId ? lane(symbols[u], k) : 0;
      if constexpr (kTwoCodings) other_local[k] = u != kNoVertexId ? lane(other_symbols[u], k) : 0;
      out.xyz[k] = v > 0 ? xyz[3 * size_t{w} + k] : 0;
    }
    return out;
  }
  const NewestTriangle* const begin = e;
  int64_t sum[3] = {0, 0, 0};  // parallelograms
  int64_t mid[3] = {0, 0, 0};  // n + p, for the midpoints when there is no parallelogram
  uint64_t lanes = 0;          // the neighbours' symbols, per axis
  uint64_t other_lanes = 0;
  int64_t count = 0;
  const uint32_t entries = static_cast<uint32_t>(end - e);
  for (; e != end; ++e) {
    const int32_t* n = xyz + 3 * size_t{e->n};
    const int32_t* p = xyz + 3 * size_t{e->p};
    lanes += uint64_t{symbols[e->n]} + symbols[e->p];
    if constexpr (kTwoCodings) other_lanes += uint64_t{other_symbols[e->n]} + other_symbols[e->p];
    // Without a branch: an absent o adds nothing (and reads n, which exists).
    const bool use = e->o != kNoVertexId && (mode == kAverageAll || count == 0);
    const int32_t* o = xyz + 3 * size_t{use ? e->o : e->n};
    const int64_t w = use ? 1 : 0;
    const bool blend = apex != 0 && use;
    int64_t blended[3];
    if (blend) blend_apex(n, p, o, apex, blended);
    for (int k = 0; k < 3; ++k) {
      const int64_t np = int64_t{n[k]} + p[k];
      mid[k] += np;
      sum[k] += blend ? blended[k] : w * (np - o[k]);
    }
    count += w;
  }
  mean_symbols(begin, end, lanes, symbols, out.local);
  if constexpr (kTwoCodings) mean_symbols(begin, end, other_lanes, other_symbols, other_local);
  if (count > 0) {
    out.kind = count > 1 ? kMultiParallelogram : kParallelogram;
    for (int k = 0; k < 3; ++k) out.xyz[k] = rounded_mean(sum[k], count);
  } else {
    out.kind = kNeighbour;
    for (int k = 0; k < 3; ++k) out.xyz[k] = rounded_mean(mid[k], 2 * int64_t{entries});
  }
  return out;
}

// Context model, per axis: the prediction kind; the residual magnitude around the vertex on that
// axis (the mean of its decoded neighbours' symbols: surfaces are locally smooth or locally
// rough); and the previous vertex's symbol on that axis (marching-cubes surfaces are rough along
// some axes and not others, and neighbouring ids are close on the surface). Nothing in a
// vertex's contexts depends on its own symbols, so its three symbols decode side by side.
struct ContextModel {
  uint32_t activity_classes;
  uint32_t previous_classes;
  // The context's three terms, looked up: kind, local (< 128) and previous symbol (< 128).
  std::array<uint16_t, 2 * kKinds> kind_term;  // kind + kKinds: the tangent plane's normal axis
  std::array<uint16_t, 128> local_term;
  std::array<uint16_t, 128> previous_term;

  explicit ContextModel(uint32_t vertex_count)
      : activity_classes(vertex_count < 2000 ? 2 : (vertex_count < 50000 ? 6 : 10)),
        previous_classes(vertex_count < 2000 ? 1 : 6) {
    for (uint32_t k = 0; k < 2 * kKinds; ++k) {
      kind_term[k] = static_cast<uint16_t>(k * activity_classes * previous_classes);
    }
    for (uint32_t i = 0; i < 128; ++i) {
      local_term[i] = static_cast<uint16_t>(std::min(i, activity_classes - 1) * previous_classes);
      previous_term[i] = static_cast<uint16_t>(std::min(i >> 1, previous_classes - 1));
    }
  }

  /// Plain coding's; tangent-plane coding has twice as many, its normal axis apart.
  uint32_t contexts(bool tangent_plane) const {
    return (tangent_plane ? 2 : 1) * kKinds * activity_classes * previous_classes;
  }
  /// The kind term of axis k's context: the prediction's kind, plus kKinds on the tangent plane's
  /// normal axis (kNoAxis for none), whose residual codes in contexts of its own.
  static uint32_t axis_kind(PredictionKind kind, int k, uint32_t normal_axis) {
    return kind + (uint32_t(k) == normal_axis ? uint32_t{kKinds} : 0u);
  }
  /// (kind * activity_classes + min(local, activity_classes - 1)) * previous_classes
  ///   + min(previous_symbol >> 1, previous_classes - 1); local, previous_symbol < 128; kind is
  ///   a PredictionKind, plus kKinds for the tangent plane's normal axis.
  uint32_t context(uint32_t kind, uint32_t local, uint32_t previous_symbol) const {
    return kind_term[kind] + local_term[local & 127] + previous_term[previous_symbol & 127];
  }
};

// Bits a symbol stream would cost under the context model, from its histogram. The tables are
// left out: a few hundred bytes, though the tangent plane's codings may use up to twice as many
// contexts, which this favours slightly on small meshes.
double estimated_bits(const std::vector<uint32_t>& histogram, uint32_t contexts,
                      uint64_t raw_bits) {
  double bits = double(raw_bits);
  for (uint32_t c = 0; c < contexts; ++c) {
    const uint32_t* h = histogram.data() + size_t{c} * kResidualSymbols;
    double total = 0;
    for (uint32_t s = 0; s < kResidualSymbols; ++s) total += h[s];
    for (uint32_t s = 0; s < kResidualSymbols; ++s) {
      if (h[s] != 0) bits += h[s] * std::log2(total / h[s]);
    }
  }
  return bits;
}

// The vertices the encoder measures each coding on before it chooses one (encode_geometry).
constexpr uint32_t kMeasuredVertices = 16384;

// Version 2's lattice coding (see the top of the file): a mask symbol, then three residual
// symbols, per vertex, in one symbol section.
constexpr uint32_t kMaxLattice = uint32_t{1} << 24;  // lattice periods 2..2^24 grid steps
constexpr uint32_t kNoAxis = 3;
constexpr uint32_t kMaskContexts = 4 * 8;            // dominant axis (or none) x previous mask
constexpr uint32_t kPlaneContexts = kKinds * 2 * 4;  // kind x (dominant axis?) x local
constexpr uint32_t kFreeContexts = kKinds * 8;       // kind x local
constexpr uint32_t kPlaneBase = kMaskContexts;
constexpr uint32_t kFreeBase = kPlaneBase + kPlaneContexts;
constexpr uint32_t kLatticeContexts = kFreeBase + kFreeContexts;
/// Symbols a vertex codes: three residuals, and lattice coding's mask before them.
inline uint32_t symbols_per_vertex(uint64_t lattice) {
  return lattice != 0 ? 4 : 3;
}

/// The normal of v's neighbouring triangles (n, p, o), summed: (n - o) x (p - o) over v's
/// parallelograms (zero when it has none). Wrapping 64-bit arithmetic: the same on both sides
/// whatever the coordinates (corrupt streams too), and exact on grids of up to 24 bits.
struct Normal {
  uint64_t xyz[3] = {0, 0, 0};
  uint32_t axis = kNoAxis;  // the largest component's axis (ties to the lower), kNoAxis for zero
};

inline Normal parallelogram_normal(uint32_t v, const NewestTriangles& nt, const int32_t* xyz) {
  const NewestTriangle* e = nt.entries.data() + nt.first[v];
  const NewestTriangle* const end = nt.entries.data() + nt.first[v + 1];
  Normal normal;
  for (; e != end; ++e) {
    if (e->o == kNoVertexId) continue;
    const int32_t* n = xyz + 3 * size_t{e->n};
    const int32_t* p = xyz + 3 * size_t{e->p};
    const int32_t* o = xyz + 3 * size_t{e->o};
    uint64_t a[3], b[3];
    for (int k = 0; k < 3; ++k) {
      a[k] = uint64_t(int64_t{n[k]} - o[k]);
      b[k] = uint64_t(int64_t{p[k]} - o[k]);
    }
    normal.xyz[0] += a[1] * b[2] - a[2] * b[1];
    normal.xyz[1] += a[2] * b[0] - a[0] * b[2];
    normal.xyz[2] += a[0] * b[1] - a[1] * b[0];
  }
  uint64_t size[3];
  for (int k = 0; k < 3; ++k) size[k] = magnitude(normal.xyz[k]);
  if ((size[0] | size[1] | size[2]) != 0) {
    const uint32_t axis = size[1] > size[0] ? 1 : 0;
    normal.axis = size[2] > size[axis] ? 2 : axis;
  }
  return normal;
}

/// floor(a / b) for b >= 1.
inline int64_t floor_div(int64_t a, int64_t b) {
  const int64_t d = a / b;
  return d - ((a % b != 0) & (a < 0));
}

/// Tangent-plane prediction (stream version 3): the prediction `pred` of the normal's largest
/// axis d moved onto the plane through the prediction with that normal, given the residuals r
/// of the other two axes a and b (decoded first, or read beside it):
///   pred - round((N[a] r[a] + N[b] r[b]) / N[d]), clamped to int32.
/// The normal is first shifted right until |N[d]| < 2^24, so that with |r| < 2^34 every product
/// and sum fits 64 bits. N[d] != 0 (the normal has an axis).
inline int64_t on_tangent_plane(const Normal& normal, int64_t pred, const int64_t r[3]) {
  const uint32_t d = normal.axis;
  const uint32_t a = d == 0 ? 1 : 0;
  const uint32_t b = d == 2 ? 1 : 2;
  const int shift = std::max(0, static_cast<int>(std::bit_width(magnitude(normal.xyz[d]))) - 24);
  int64_t den = static_cast<int64_t>(normal.xyz[d]) >> shift;
  int64_t num = (static_cast<int64_t>(normal.xyz[a]) >> shift) * r[a] +
                (static_cast<int64_t>(normal.xyz[b]) >> shift) * r[b];
  if (den < 0) {
    den = -den;
    num = -num;
  }
  const int64_t moved = pred - floor_div(2 * num + den, 2 * den);
  return std::clamp<int64_t>(moved, INT32_MIN, INT32_MAX);
}

/// The plane index nearest the prediction: floor((pred + floor(L / 2)) / L).
inline int64_t nearest_plane(int64_t pred, int64_t lattice) {
  return floor_div(pred + lattice / 2, lattice);
}

inline uint32_t mask_context(uint32_t dominant, uint32_t previous_mask) {
  return dominant * 8 + previous_mask;
}
inline uint32_t plane_context(PredictionKind kind, bool dominant, uint32_t local) {
  return kPlaneBase + (kind * 2 + (dominant ? 1 : 0)) * 4 + std::min(local, 3u);
}
inline uint32_t free_context(PredictionKind kind, uint32_t local) {
  return kFreeBase + kind * 8 + std::min(local, 7u);
}

// One loop for both codings (lattice 0: plain residuals; else lattice coding), so that the
// WebAssembly decoder holds one copy of the prediction and the symbol reads: the lattice branches
// go the same way for every vertex of a stream.
OSTEON_NOINLINE Status decode_loop(const NewestTriangles& nt, const ContextModel& model,
                                   PredictionMode mode, uint32_t apex, bool tangent_plane,
                                   int64_t lattice, SymbolDecoder& dec, ByteReader& in,
                                   const std::string& source, QuantizedPositions* q) {
  const uint32_t vertex_count = static_cast<uint32_t>(q->xyz.size() / 3);
  // Written before being read, so not cleared.
  const std::unique_ptr<uint32_t[]> symbols(new uint32_t[vertex_count]);
  int32_t* const xyz = q->xyz.data();
  SymbolDecoder::Cursor cursor = dec.cursor();  // in registers through the loop
  uint32_t previous[3] = {0, 0, 0};
  uint32_t mask = 0;  // lattice coding: the axes on lattice planes
  for (uint32_t v = 0; v < vertex_count; ++v) {
    const Prediction pred = predict(v, nt, xyz, symbols.get(), mode, apex);
    // Lattice coding and the tangent plane read the normal; never both (decode_geometry checks).
    Normal normal;
    if (lattice != 0 || tangent_plane) normal = parallelogram_normal(v, nt, xyz);
    uint32_t context[3];
    if (lattice == 0) [[likely]] {
      // normal.axis is none without the tangent plane.
      for (int k = 0; k < 3; ++k) {
        const uint32_t kind = ContextModel::axis_kind(pred.kind, k, normal.axis);
        context[k] = model.context(kind, pred.local[k], previous[k]);
      }
    } else {
      const uint32_t dominant = normal.axis;
      mask = dec.get(cursor, mask_context(dominant, mask & 7));
      for (int k = 0; k < 3; ++k) {
        context[k] = ((mask >> k) & 1)
                         ? plane_context(pred.kind, dominant == uint32_t(k), pred.local[k])
                         : free_context(pred.kind, pred.local[k]);
      }
    }
    uint32_t symbol[3];
    dec.get3(cursor, context, symbol);
    // The raw bits (get_residual()), without a branch on whether there are any (a coin toss the
    // branch predictor loses), the three axes' in one read where they fit in 56 bits (symbols
    // below 40 each: nearly always).
    const uint32_t bits[3] = {kRawBits[symbol[0]], kRawBits[symbol[1]], kRawBits[symbol[2]]};
    uint64_t rest[3];
    if (bits[0] + bits[1] + bits[2] <= 56) [[likely]] {
      const uint64_t all = dec.get_bits(cursor, static_cast<int>(bits[0] + bits[1] + bits[2]));
      rest[0] = all & ((uint64_t{1} << bits[0]) - 1);
      rest[1] = (all >> bits[0]) & ((uint64_t{1} << bits[1]) - 1);
      rest[2] = all >> (bits[0] + bits[1]);
    } else {
      for (int k = 0; k < 3; ++k) {
        rest[k] = bits[k] > 32 ? dec.get_bits(cursor, 32) |
                                     dec.get_bits(cursor, static_cast<int>(bits[k]) - 32) << 32
                               : dec.get_bits(cursor, static_cast<int>(bits[k]));
      }
    }
    int64_t r[3];
    int64_t base[3];
    for (int k = 0; k < 3; ++k) {
      r[k] = unzigzag(kLeadingBits[symbol[k]] | rest[k]);
      base[k] = pred.xyz[k];
    }
    if (normal.axis != kNoAxis && tangent_plane) {
      base[normal.axis] = on_tangent_plane(normal, base[normal.axis], r);
    }
    bool in_range = mask < 8;
    for (int k = 0; k < 3; ++k) {
      int64_t value = base[k] + r[k];
      // On a lattice plane: |r| < 2^34 and lattice <= 2^24, so no overflow before the check.
      if ((mask >> k) & 1) value = (nearest_plane(pred.xyz[k], lattice) + r[k]) * lattice;
      in_range = in_range & (value >= INT32_MIN) & (value <= INT32_MAX);
      xyz[3 * size_t{v} + k] = static_cast<int32_t>(value);
      previous[k] = symbol[k];
    }
    symbols[v] = pack_symbols(symbol[0], symbol[1], symbol[2]);
    if (!cursor.ok || !in_range) [[unlikely]] {
      return error(ErrorCode::kInvalidData, source,
                   message("geometry: corrupt residual for vertex %", {v}), at_byte(in.offset()));
    }
  }
  dec.resume(cursor);
  return Status::ok_status();
}

// The encoder's tangent plane for v, whose coordinates are known: `base` (its prediction) with
// the normal's largest axis moved onto the plane, as the decoder will move it.
inline uint32_t move_onto_tangent_plane(uint32_t v, const NewestTriangles& nt, const int32_t* xyz,
                                        int64_t base[3]) {
  const Normal normal = parallelogram_normal(v, nt, xyz);
  if (normal.axis == kNoAxis) return kNoAxis;
  int64_t r[3];
  for (int k = 0; k < 3; ++k) r[k] = int64_t{xyz[3 * size_t{v} + k]} - base[k];
  base[normal.axis] = on_tangent_plane(normal, base[normal.axis], r);
  return normal.axis;
}

// Plain residuals of one vertex (coordinates `at`) from `base`: hands each axis's (context,
// symbol, z) to `sink`, updates `previous` and returns the packed symbols. normal_axis: the
// tangent plane's, which codes in contexts of its own (kNoAxis for none).
template <class Sink>
inline uint32_t code_plain(const int32_t* at, const int64_t base[3], PredictionKind kind,
                           uint32_t normal_axis, const uint32_t local[3], const ContextModel& model,
                           uint32_t previous[3], Sink& sink) {
  uint32_t symbol[3];
  for (int k = 0; k < 3; ++k) {
    const uint64_t z = zigzag(int64_t{at[k]} - base[k]);
    symbol[k] = residual_symbol(z);
    sink(model.context(ContextModel::axis_kind(kind, k, normal_axis), local[k], previous[k]),
         symbol[k], z, true);
    previous[k] = symbol[k];
  }
  return pack_symbols(symbol[0], symbol[1], symbol[2]);
}

// Where a coding's encoder loop stands: the vertices before `next` (in decoding order) are
// coded, and what the next vertex's prediction and contexts read of them is kept.
struct LoopState {
  uint32_t next = 0;
  std::vector<uint32_t> symbols;  // per vertex before `next`: its packed symbols
  uint32_t previous[3] = {0, 0, 0};
  uint32_t previous_mask = 0;
};

// The encoder's prediction loop, for both codings as decode_loop reads them (lattice 0: plain
// residuals in the context model's contexts; else a mask symbol, then lattice coding): codes the
// vertices from state->next up to `end`, handing each (context, symbol, z, is_residual) to `sink`
// (the mask symbol has no raw bits).
template <class Sink>
void encode_loop(const NewestTriangles& nt, const QuantizedPositions& q, const ContextModel& model,
                 PredictionMode mode, uint32_t apex, bool tangent_plane, int64_t lattice,
                 uint32_t end, LoopState* state, Sink&& sink) {
  assert(state->next <= end && end <= q.xyz.size() / 3);
  state->symbols.resize(end);
  uint32_t* const symbols = state->symbols.data();
  const int32_t* xyz = q.xyz.data();
  uint32_t* const previous = state->previous;
  uint32_t previous_mask = state->previous_mask;
  for (uint32_t v = state->next; v < end; ++v) {
    const Prediction pred = predict(v, nt, xyz, symbols, mode, apex);
    if (lattice == 0) {
      int64_t base[3] = {pred.xyz[0], pred.xyz[1], pred.xyz[2]};
      const uint32_t axis = tangent_plane ? move_onto_tangent_plane(v, nt, xyz, base) : kNoAxis;
      symbols[v] =
          code_plain(xyz + 3 * size_t{v}, base, pred.kind, axis, pred.local, model, previous, sink);
      continue;
    }
    uint32_t symbol[3];
    const uint32_t dominant = parallelogram_normal(v, nt, xyz).axis;
    uint32_t mask = 0;
    for (int k = 0; k < 3; ++k) {
      mask |= (xyz[3 * size_t{v} + k] % lattice == 0 ? 1u : 0u) << k;
    }
    sink(mask_context(dominant, previous_mask), mask, 0, false);
    previous_mask = mask;
    for (int k = 0; k < 3; ++k) {
      const int64_t c = xyz[3 * size_t{v} + k];
      if (((mask >> k) & 1)) {
        const uint64_t z = zigzag(c / lattice - nearest_plane(pred.xyz[k], lattice));
        symbol[k] = residual_symbol(z);
        sink(plane_context(pred.kind, dominant == uint32_t(k), pred.local[k]), symbol[k], z, true);
      } else {
        const uint64_t z = zigzag(c - pred.xyz[k]);
        symbol[k] = residual_symbol(z);
        sink(free_context(pred.kind, pred.local[k]), symbol[k], z, true);
      }
    }
    symbols[v] = pack_symbols(symbol[0], symbol[1], symbol[2]);
  }
  state->next = end;
  state->previous_mask = previous_mask;
}

// Plain residuals of the first `end` vertices under one parallelogram mode, without and with the
// tangent plane, in one pass: the two codings share the prediction, and differ from their own
// symbols on (the neighbours' activity in their contexts). For measuring; both resume where
// they stand, at the same vertex.
template <class FlatSink, class PlaneSink>
void encode_pair(const NewestTriangles& nt, const QuantizedPositions& q, const ContextModel& model,
                 PredictionMode mode, uint32_t apex, uint32_t end, LoopState* flat,
                 LoopState* plane, FlatSink&& flat_sink, PlaneSink&& plane_sink) {
  assert(flat->next == plane->next && flat->next <= end && end <= q.xyz.size() / 3);
  flat->symbols.resize(end);
  plane->symbols.resize(end);
  const int32_t* xyz = q.xyz.data();
  for (uint32_t v = flat->next; v < end; ++v) {
    uint32_t plane_local[3];
    const Prediction pred = predict<true>(v, nt, xyz, flat->symbols.data(), mode, apex,
                                          plane->symbols.data(), plane_local);
    const int32_t* at = xyz + 3 * size_t{v};
    int64_t base[3] = {pred.xyz[0], pred.xyz[1], pred.xyz[2]};
    flat->symbols[v] =
        code_plain(at, base, pred.kind, kNoAxis, pred.local, model, flat->previous, flat_sink);
    const uint32_t axis = move_onto_tangent_plane(v, nt, xyz, base);
    plane->symbols[v] =
        code_plain(at, base, pred.kind, axis, plane_local, model, plane->previous, plane_sink);
  }
  flat->next = end;
  plane->next = end;
}

// The apex weight the encoder codes with (0: none). Each weight's residuals are estimated, by
// their bit lengths, on up to kApexSamples vertices spread over the measured prefix; the weight
// only blends two predictions, so the two ends (0 and 8 eighths) give every other by
// interpolation. The apex is kept only where it is estimated to save at least kApexGain of
// those bits: its prediction costs an integer square root and a division per parallelogram, in
// the decoder too, and the estimate promises about twice what coding then saves (on the codec
// bench's meshes, a 3% estimate saved 0.5 to 2%).
constexpr uint32_t kApexSamples = 256;
constexpr double kApexGain = 0.03;
uint32_t choose_apex(const NewestTriangles& nt, const QuantizedPositions& q, uint32_t end,
                     int64_t lattice) {
  std::vector<uint32_t> no_symbols(end, 0);  // the contexts' terms do not matter here
  const int32_t* xyz = q.xyz.data();
  uint64_t cost[kApexWeights] = {};
  const uint32_t stride = std::max(1u, end / kApexSamples);
  for (uint32_t v = 0; v < end; v += stride) {
    const Prediction flat = predict(v, nt, xyz, no_symbols.data(), kAverageAll, 0);
    if (flat.kind > kParallelogram) continue;
    const Prediction apex = predict(v, nt, xyz, no_symbols.data(), kAverageAll, 8);
    for (int k = 0; k < 3; ++k) {
      const int64_t c = xyz[3 * size_t{v} + k];
      const bool on_plane = lattice != 0 && c % lattice == 0;
      for (uint32_t a = 0; a < kApexWeights; ++a) {
        const int64_t pred = flat.xyz[k] + floor_div((apex.xyz[k] - flat.xyz[k]) * a + 4, 8);
        cost[a] +=
            bit_length(zigzag(on_plane ? c / lattice - nearest_plane(pred, lattice) : c - pred));
      }
    }
  }
  uint32_t best = 0;
  for (uint32_t a = 1; a < kApexWeights; ++a) {
    if (cost[a] < cost[best]) best = a;
  }
  return double(cost[best]) <= (1 - kApexGain) * double(cost[0]) ? best : 0;
}

}  // namespace

void encode_geometry(const NewestTriangles& nt, const QuantizedPositions& q, uint32_t lattice,
                     std::vector<uint8_t>* out) {
  const uint32_t vertex_count = static_cast<uint32_t>(q.xyz.size() / 3);
  assert(nt.first.size() == size_t{vertex_count} + 1 && nt.neighbour.size() == vertex_count);
  const ContextModel model(vertex_count);
  if (lattice < 2 || lattice > kMaxLattice) lattice = 0;

  // Choose the apex weight (choose_apex), then measure the codings (both parallelogram modes,
  // with and without the tangent plane, and on the lattice where there is one) with it, and code
  // with the cheapest.
  // They are measured on a prefix in decoding order, a connected patch coded as the whole mesh
  // codes it (its contexts come from vertices before): a quarter of the vertices, at least
  // kMeasuredVertices / 4 and at most kMeasuredVertices. Measuring every vertex took 2-4 passes
  // as long as the coding pass; the prefix codes the codec bench's 74 meshes to the same sizes.
  // Each measured coding queues its symbols as it goes, so the one kept resumes after its
  // prefix instead of predicting it again.
  const uint32_t measured = std::min(
      {vertex_count, kMeasuredVertices, std::max(kMeasuredVertices / 4, vertex_count / 4)});
  const uint32_t apex = choose_apex(nt, q, measured, lattice);
  struct Coding {
    uint8_t mode;  // the mode byte's low bits: PredictionMode + kModes for the tangent plane
    uint32_t lattice;
    LoopState state;
    SymbolEncoder enc;
    double bits;
  };
  auto queue = [](SymbolEncoder& enc) {
    return [&enc](uint32_t context, uint32_t symbol, uint64_t z, bool residual) {
      enc.put(context, symbol);
      if (residual) put_residual_bits(enc, symbol, z);
    };
  };
  auto run = [&](Coding& coding, uint32_t end, auto&& sink) {
    encode_loop(nt, q, model, PredictionMode(coding.mode % kModes), apex, coding.mode >= kModes,
                coding.lattice, end, &coding.state, sink);
  };
  // The candidates, in the order that breaks ties: plain residuals in modes 0 to 3 (the
  // parallelogram modes without, then with the tangent plane), then lattice coding's modes
  // (lattice coding has its own use of the normal, and no tangent plane). Each queues its
  // symbols as it goes; its size is estimated from what it queued.
  std::vector<Coding> codings;
  auto add = [&](uint8_t mode, uint32_t coding_lattice, uint32_t contexts) {
    codings.push_back(
        {mode, coding_lattice, LoopState(), SymbolEncoder(kResidualSymbols, contexts), 0});
    codings.back().enc.reserve(size_t{measured} * symbols_per_vertex(coding_lattice));
    codings.back().state.symbols.reserve(measured);
  };
  for (uint32_t m = 0; m < 2 * kModes; ++m) {
    add(static_cast<uint8_t>(m), 0, model.contexts(m >= kModes));
  }
  for (uint32_t m = 0; lattice != 0 && m < kModes; ++m) {
    add(static_cast<uint8_t>(m), lattice, kLatticeContexts);
  }
  std::vector<uint32_t> histogram;  // one coding's at a time
  auto estimate = [&](const Coding& c) {
    const uint32_t contexts = c.lattice != 0 ? kLatticeContexts : model.contexts(c.mode >= kModes);
    histogram.assign(size_t{contexts} * kResidualSymbols, 0);
    for (uint32_t entry : c.enc.queued()) {
      ++histogram[size_t{entry >> SymbolEncoder::kContextShift} * kResidualSymbols +
                  (entry & ((1u << SymbolEncoder::kContextShift) - 1))];
    }
    return estimated_bits(histogram, contexts, c.enc.raw_bit_count());
  };
  // Two stages: the first kFirstStage vertices, where one coding usually leads every other by
  // more than kClearLead already; only a close call is measured on the whole prefix (and that
  // chose as measuring it all did on the codec bench's 74 meshes).
  constexpr uint32_t kFirstStage = 1024;
  constexpr double kClearLead = 1.02;
  size_t best = 0;
  for (const uint32_t end : {std::min(measured, kFirstStage), measured}) {
    for (uint32_t m = 0; m < kModes; ++m) {  // a parallelogram mode's two plain codings at once
      Coding& flat = codings[m];
      Coding& plane = codings[m + kModes];
      encode_pair(nt, q, model, PredictionMode(m), apex, end, &flat.state, &plane.state,
                  queue(flat.enc), queue(plane.enc));
    }
    for (size_t i = 2 * kModes; i < codings.size(); ++i) {
      run(codings[i], end, queue(codings[i].enc));
    }
    best = 0;
    for (size_t i = 0; i < codings.size(); ++i) {
      codings[i].bits = estimate(codings[i]);
      if (codings[i].bits < codings[best].bits) best = i;  // of equals, the first
    }
    bool clear = true;
    for (size_t i = 0; i < codings.size(); ++i) {
      if (i != best && codings[i].bits <= codings[best].bits * kClearLead) clear = false;
    }
    if (clear) break;
  }
  Coding& kept = codings[best];

  out->push_back(static_cast<uint8_t>(kept.mode | apex << kApexShift));
  ByteWriter writer(out);
  writer.write_varint(kept.lattice);
  kept.enc.reserve(size_t{vertex_count - kept.state.next} * symbols_per_vertex(kept.lattice));
  run(kept, vertex_count, queue(kept.enc));
  kept.enc.append_to(out);
}

OSTEON_COLD_FUNCTION Result<QuantizedPositions> decode_geometry(ByteReader& in,
                                                                const NewestTriangles& nt,
                                                                uint32_t vertex_count,
                                                                uint8_t version,
                                                                const std::string& source) {
  if (nt.first.size() != size_t{vertex_count} + 1 || nt.neighbour.size() != vertex_count) {
    return error(ErrorCode::kInvalidArgument, source,
                 message("geometry: the connectivity does not have % vertices", {vertex_count}));
  }
  uint8_t mode = 0;
  const bool read = in.read_le(&mode);
  const uint32_t apex = mode >> kApexShift;
  mode &= (1u << kApexShift) - 1;
  if (!read || mode >= (version >= 3 ? 2 * kModes : kModes) ||
      apex >= (version >= 4 ? kApexWeights : 1)) {
    return error(ErrorCode::kInvalidData, source, "geometry: unknown prediction mode",
                 at_byte(in.offset()));
  }
  uint64_t lattice = 0;  // version 2: the lattice period, 0 for none
  if (version >= 2 && (!in.read_varint(&lattice) || lattice == 1 || lattice > kMaxLattice ||
                       (lattice != 0 && mode >= kModes))) {
    return error(ErrorCode::kInvalidData, source, "geometry: bad lattice period",
                 at_byte(in.offset()));
  }
  const ContextModel model(vertex_count);
  SymbolDecoder dec;
  OSTEON_RETURN_IF_ERROR(dec.init(in, kResidualSymbols,
                                  lattice != 0 ? kLatticeContexts : model.contexts(mode >= kModes),
                                  source, "geometry"));
  if (dec.symbols_left() != uint64_t{symbols_per_vertex(lattice)} * vertex_count) {
    return error(
        ErrorCode::kInvalidData, source,
        message("geometry: % residual symbols for % vertices", {dec.symbols_left(), vertex_count}),
        at_byte(in.offset()));
  }
  QuantizedPositions q;
  q.xyz.resize(size_t{vertex_count} * 3);
  OSTEON_RETURN_IF_ERROR(decode_loop(nt, model, PredictionMode(mode % kModes), apex, mode >= kModes,
                                     int64_t(lattice), dec, in, source, &q));
  OSTEON_RETURN_IF_ERROR(dec.finish(source, "geometry"));
  return q;
}

}  // namespace osteon::detail
