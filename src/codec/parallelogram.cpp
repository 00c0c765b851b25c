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

#include "codec/codec_internal.hpp"
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
// The triangle shape (stream version 5; version 4's apex weight is a special case): each
// parallelogram's offset from its edge's midpoint may be scaled, and blended with the apex of the
// equilateral triangle on the edge (n, p), in the plane of (n, p, o), away from o
// (shaped_parallelogram). A parallelogram copies the shape of o's triangle: on irregular
// triangles (decimated meshes) a shrunken offset misses by less, and where triangles scatter
// around equilateral (smoothed isosurfaces, raw marching cubes) the apex does.
// The encoder chooses the shape per mesh (choose_shape).
//
// The refinements (stream version 6; Refinement): a vertex without parallelograms steps out from
// the decoded neighbour it copied, away from that neighbour's own neighbours (extrapolation), and
// a prediction follows its neighbours' misses along the normal (the curvature step). The encoder
// chooses both weights per mesh (choose_extrapolation, choose_curvature and a trial coding).
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
  // For version 5's contexts: per axis, the bit length of the spread (largest less smallest) of
  // the parallelograms' values (0 with fewer than two); the bit length of the largest coordinate
  // difference along the edges (n, p) of v's triangles (0 without any).
  uint32_t spread_bits[3];
  uint32_t reach_bits;
};

/// Per axis, the rounded mean of the symbols of the 2 * entries neighbours of v's entries
/// [begin, end), given `lanes`, their packed symbols summed (Prediction::local).
inline void mean_symbols(const NewestTriangle* begin, const NewestTriangle* end, uint64_t lanes,
                         const uint32_t* symbols, uint32_t local[3]) {
  const uint32_t entries = static_cast<uint32_t>(end - begin);
  if (entries <= kMaxSmallDivisor / 2) [[likely]] {
    OSTEON_UNROLL
    for (int k = 0; k < 3; ++k) {
      local[k] = ((lane(lanes, k) + entries) * kReciprocal[2 * entries]) >> 16;
    }
  } else {
    // Lanes may overflow into each other beyond 16 entries: add them up again, apart.
    uint32_t sums[3] = {0, 0, 0};
    for (const NewestTriangle* f = begin; f != end; ++f) {
      OSTEON_UNROLL
      for (int k = 0; k < 3; ++k) sums[k] += lane(symbols[f->n], k) + lane(symbols[f->p], k);
    }
    OSTEON_UNROLL
    for (int k = 0; k < 3; ++k) local[k] = (sums[k] + entries) / (2 * entries);
  }
}

/// |x| of a 64-bit two's-complement value, as unsigned (0 - x for a negative one).
inline uint64_t magnitude(uint64_t x) {
  return x >> 63 ? 0 - x : x;
}

/// floor(a / b) for b >= 1.
inline int64_t floor_div(int64_t a, int64_t b) {
  const int64_t d = a / b;
  return d - ((a % b != 0) & (a < 0));
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

/// Stream version 4's apex weight A, 0 to 8 eighths, sits in the geometry mode byte's bits from
/// kApexShift up (below them, the prediction mode); it is the triangle shape {16 - 2A, 2A} below.
/// From version 5 on, bit kShapeFlag says that the shape's two weights follow.
constexpr uint32_t kApexWeights = 9;
constexpr int kApexShift = 2;
constexpr uint8_t kShapeFlag = 1u << kApexShift;
/// floor(sqrt(3) 2^45), the apex's height over its edge in fixed point.
constexpr int64_t kRootThree = 60941120090265;
/// From version 6 on, bit kRefineFlag says that the two weights of the Refinement follow (after
/// the shape's, if any).
constexpr uint8_t kRefineFlag = 1u << (kApexShift + 1);

/// Stream version 6's two refinements of a prediction, each in sixteenths, 0 (off) to
/// kMaxShapeWeight:
/// - extrapolation: a vertex with no triangle of decoded vertices (about one in ten on decimated
///   meshes, by the decoding order) is predicted from a decoded neighbour u. Such a vertex lies
///   beyond the decoded part of u's ring, so the prediction steps out from u, away from the mean
///   c of u's own triangles' other vertices: q[u] + floor((extrapolation (q[u] - c) + 8) / 16)
///   (step_out);
/// - curvature: a parallelogram continues the surface flat, so on a curved surface it misses
///   along the normal by about as much as its neighbours' own predictions missed. The
///   prediction moves along its parallelograms' normal by `curvature` sixteenths of the normal
///   part of its neighbours' mean residual (curvature_step), before the tangent plane, if any.
///   Not with lattice coding.
struct Refinement {
  int32_t extrapolation = 0;
  int32_t curvature = 0;
  bool none() const { return extrapolation == 0 && curvature == 0; }
};
// The extrapolation weight without the encoder's search (EncodeOptions::effort 0): the middle of
// what the search chooses (8 to 14 on BodyParts3D's bones, 16 to 20 on Visible Human's, 8 to 22
// on PSB's).
constexpr int32_t kFastExtrapolation = 12;

/// How a parallelogram's vertex is placed from the triangle (n, p, o) across its edge, in
/// sixteenths (stream version 5; version 4's apex weight is a special case): from the edge's
/// midpoint m = (n + p) / 2, the parallelogram moves by t / 2, t = n + p - 2o. A shape moves by
/// `scale` sixteenths of that, plus `apex` sixteenths of the offset of the equilateral triangle's
/// apex (sqrt(3) / 2 |p - n| across the edge, in the plane of (n, p, o), away from o). {16, 0} is
/// the parallelogram. Irregular triangles (decimated meshes) copy o's shape badly: a shrunken
/// offset misses by less; triangles that scatter around equilateral (smoothed isosurfaces, raw
/// marching cubes) miss the apex by less.
struct TriangleShape {
  int32_t scale = 16;
  int32_t apex = 0;
  bool parallelogram() const { return scale == 16 && apex == 0; }
};
/// Each weight of a stream's shape is at most this many sixteenths.
constexpr int32_t kMaxShapeWeight = 32;
inline TriangleShape apex_shape(uint32_t apex) {
  const int32_t a = static_cast<int32_t>(apex);
  return {16 - 2 * a, 2 * a};
}

/// Twice the apex's offset from the edge's midpoint (shaped_parallelogram's 2d). In integers, so
/// that every platform predicts the same:
///   e = p - n, t = n + p - 2o, both shifted right by s until every component fits 15 bits;
///   c = t x e, the triangle's normal, scaled so that its largest component has 30 bits;
///   2d = floor(((e x c) floor(kRootThree / isqrt(c.c)) + 2^44) / 2^45) 2^s: sqrt(3) |e| across
///   the edge, in the triangle's plane; zero without a triangle (c zero: o on the line through n
///   and p).
inline void apex_offset(const int32_t* n, const int32_t* p, const int32_t* o, int64_t apex[3]) {
  int64_t e[3], t[3];
  uint64_t big = 0;
  OSTEON_UNROLL
  for (int k = 0; k < 3; ++k) {
    e[k] = int64_t{p[k]} - n[k];
    t[k] = int64_t{n[k]} + p[k] - 2 * int64_t{o[k]};
    big |= magnitude(uint64_t(e[k])) | magnitude(uint64_t(t[k]));
  }
  const int s = std::max(0, static_cast<int>(std::bit_width(big)) - 15);
  OSTEON_UNROLL
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
  OSTEON_UNROLL
  for (int k = 0; k < 3; ++k) {
    apex[k] = ((across[k] * ratio + (int64_t{1} << 44)) >> 45) * (int64_t{1} << s);
  }
}

/// One parallelogram's prediction under `shape` (not the parallelogram itself):
///   value = floor((16 (n + p) + scale t + apex 2d + 16) / 32), clamped to +-(2^33 - 1),
/// 2d computed only where apex != 0. Version 4's apex weight A gives exactly version 4's blend
/// floor(((8 - A) 2 (n + p - o) + A (n + p + 2d) + 8) / 16).
inline void shaped_parallelogram(const int32_t* n, const int32_t* p, const int32_t* o,
                                 const TriangleShape& shape, int64_t value[3]) {
  int64_t apex[3] = {0, 0, 0};
  if (shape.apex != 0) apex_offset(n, p, o, apex);
  constexpr int64_t kLimit = (int64_t{1} << 33) - 1;
  OSTEON_UNROLL
  for (int k = 0; k < 3; ++k) {
    const int64_t np = int64_t{n[k]} + p[k];
    const int64_t t = np - 2 * int64_t{o[k]};
    value[k] =
        std::clamp((16 * np + shape.scale * t + shape.apex * apex[k] + 16) >> 5, -kLimit, kLimit);
  }
}

/// Per axis, the rounded mean (rounded_mean) of values[n] + values[p] over vertex w's k >= 1
/// entries: floor((S[j] + k) / (2k)). Both refinements (Refinement) start from it.
OSTEON_NOINLINE void entry_mean(uint32_t w, const NewestTriangles& nt, const int32_t* values,
                                int64_t mean[3]) {
  const NewestTriangle* const begin = nt.entries.data() + nt.first[w];
  const NewestTriangle* const end = nt.entries.data() + nt.first[w + 1];
  OSTEON_UNROLL
  for (int j = 0; j < 3; ++j) {
    int64_t sum = 0;
    for (const NewestTriangle* e = begin; e != end; ++e) {
      sum += int64_t{values[3 * size_t{e->n} + j]} + values[3 * size_t{e->p} + j];
    }
    mean[j] = rounded_mean(sum, 2 * (end - begin));
  }
}

/// The extrapolation (Refinement) from a decoded neighbour at `at`, away from `mean`
/// (entry_mean of its entries), `weight` sixteenths of their difference:
///   clamp(at + floor((weight (at - mean) + 8) / 16), int32).
/// |at - mean| < 2^32 and weight <= 32: no overflow.
inline int64_t stepped_out(int64_t at, int64_t mean, int32_t weight) {
  return std::clamp<int64_t>(at + ((weight * (at - mean) + 8) >> 4), INT32_MIN, INT32_MAX);
}

/// The extrapolation of the prediction `pred` = q[u] from a decoded neighbour u, in place;
/// nothing where u has no entries.
inline void step_out(uint32_t u, const NewestTriangles& nt, const int32_t* xyz, int32_t weight,
                     int64_t pred[3]) {
  if (nt.first[u] == nt.first[u + 1]) return;
  int64_t mean[3];
  entry_mean(u, nt, xyz, mean);
  OSTEON_UNROLL
  for (int k = 0; k < 3; ++k) pred[k] = stepped_out(pred[k], mean[k], weight);
}

// The prediction of vertex v from the vertices before it; the encoder and the decoder call this
// with the same records for vertices < v, so they agree bit for bit. kTwoCodings (the encoder
// measuring two codings of the same prediction at once): also the local activity of a second
// coding's symbols, into other_local. shape: how each parallelogram places the vertex
// (TriangleShape); extrapolation: Refinement's, for a vertex without parallelograms. placed: the
// encoder's shaped_parallelogram() of every entry with an o, computed once for the several codings
// it measures (nullptr: computed here).
using Placed = std::array<int64_t, 3>;
template <bool kTwoCodings = false>
inline Prediction predict(uint32_t v, const NewestTriangles& nt, const int32_t* xyz,
                          const uint32_t* symbols, PredictionMode mode, const TriangleShape& shape,
                          int32_t extrapolation, const Placed* placed_entries = nullptr,
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
    out.reach_bits = 0;
    const uint32_t w = u != kNoVertexId ? u : v - 1;
    OSTEON_UNROLL
    for (int k = 0; k < 3; ++k) {
      out.spread_bits[k] = 0;
      out.local[k] = u != kNoVertexId ? lane(symbols[u], k) : 0;
      if constexpr (kTwoCodings) other_local[k] = u != kNoVertexId ? lane(other_symbols[u], k) : 0;
      out.xyz[k] = v > 0 ? xyz[3 * size_t{w} + k] : 0;
    }
    if (extrapolation != 0 && u != kNoVertexId) step_out(u, nt, xyz, extrapolation, out.xyz);
    return out;
  }
  const NewestTriangle* const begin = e;
  int64_t sum[3] = {0, 0, 0};  // parallelograms
  int64_t mid[3] = {0, 0, 0};  // n + p, for the midpoints when there is no parallelogram
  uint64_t lanes = 0;          // the neighbours' symbols, per axis
  uint64_t other_lanes = 0;
  int64_t count = 0;
  int64_t low[3] = {INT64_MAX, INT64_MAX, INT64_MAX};  // the parallelograms' values' range
  int64_t high[3] = {INT64_MIN, INT64_MIN, INT64_MIN};
  uint64_t reach = 0;
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
    const bool shaped = use && !shape.parallelogram();
    int64_t placed[3];
    if (shaped && placed_entries != nullptr) {
      std::copy_n(placed_entries[e - nt.entries.data()].data(), 3, placed);
    } else if (shaped) {
      shaped_parallelogram(n, p, o, shape, placed);
    }
    OSTEON_UNROLL
    for (int k = 0; k < 3; ++k) {
      const int64_t np = int64_t{n[k]} + p[k];
      const int64_t value = shaped ? placed[k] : np - o[k];
      mid[k] += np;
      sum[k] += w * value;
      low[k] = use ? std::min(low[k], value) : low[k];
      high[k] = use ? std::max(high[k], value) : high[k];
      reach |= magnitude(uint64_t(int64_t{p[k]} - n[k]));
    }
    count += w;
  }
  mean_symbols(begin, end, lanes, symbols, out.local);
  out.reach_bits = static_cast<uint32_t>(std::bit_width(reach));
  OSTEON_UNROLL
  for (int k = 0; k < 3; ++k) {
    out.spread_bits[k] =
        count > 1 ? static_cast<uint32_t>(std::bit_width(uint64_t(high[k] - low[k]))) : 0;
  }
  if constexpr (kTwoCodings) mean_symbols(begin, end, other_lanes, other_symbols, other_local);
  if (count > 0) {
    out.kind = count > 1 ? kMultiParallelogram : kParallelogram;
    OSTEON_UNROLL
    for (int k = 0; k < 3; ++k) out.xyz[k] = rounded_mean(sum[k], count);
  } else {
    out.kind = kNeighbour;
    OSTEON_UNROLL
    for (int k = 0; k < 3; ++k) out.xyz[k] = rounded_mean(mid[k], 2 * int64_t{entries});
  }
  return out;
}

// Context model, per axis: the prediction kind; the residual magnitude around the vertex on that
// axis (the mean of its decoded neighbours' symbols: surfaces are locally smooth or locally
// rough); and the previous vertex's symbol on that axis (marching-cubes surfaces are rough along
// some axes and not others, and neighbouring ids are close on the surface). Nothing in a
// vertex's contexts depends on its own symbols, so its three symbols decode side by side.
//
// Version 5 (scaled contexts): the residual's expected size, one number from a linear model of
// what predicts it, in sixteenths of a symbol: the neighbours' activity, the previous symbol, the
// spread of the vertex's parallelograms on that axis (where they disagree, each misses by about
// as much) and the length of its triangles' edges (residuals grow with the triangles). Its whole
// symbols, from 0 to bins - 1, are the classes of each kind. One model, one class per context, so
// small meshes pay for few tables. Its weights were fitted (least squares on the symbols) over
// the codec bench's meshes; the kind's bias puts each kind's classes where its residuals lie.
constexpr int32_t kScaledLocal = 7, kScaledPrevious = 1, kScaledSpread = 8, kScaledReach = 4;
constexpr int32_t kScaledBias[2 * kKinds] = {-22, 35, 115, 247, -25, 9, 0, 0};
struct ContextModel {
  uint32_t classes;  // per kind
  // The terms of a context, in sixteenths of a class: kind (< 2 * kKinds), local activity and
  // previous symbol (each < 128), looked up; the spread's and the reach's weights.
  std::array<uint16_t, 2 * kKinds> kind_term;  // kind + kKinds: the tangent plane's normal axis
  std::array<int32_t, 2 * kKinds> bias;
  std::array<int32_t, 128> local_term;
  std::array<int32_t, 128> previous_term;
  int32_t spread_weight, reach_weight;

  ContextModel(uint32_t vertex_count, uint8_t version) {
    const bool scaled = version >= 5;
    const int32_t activity = vertex_count < 2000 ? 2 : (vertex_count < 50000 ? 6 : 10);
    const int32_t previous = vertex_count < 2000 ? 1 : 6;
    classes = scaled ? (vertex_count < 2000 ? 6 : (vertex_count < 50000 ? 14 : 20))
                     : uint32_t(activity * previous);
    for (uint32_t k = 0; k < 2 * kKinds; ++k) {
      kind_term[k] = static_cast<uint16_t>(k * classes);
      bias[k] = scaled ? kScaledBias[k] : 0;
    }
    // Up to version 4, the classes are activity x previous, in whole classes (16 sixteenths).
    for (int32_t i = 0; i < 128; ++i) {
      local_term[i] = scaled ? kScaledLocal * i : 16 * std::min(i, activity - 1) * previous;
      previous_term[i] = scaled ? kScaledPrevious * i : 16 * std::min(i >> 1, previous - 1);
    }
    spread_weight = scaled ? kScaledSpread : 0;
    reach_weight = scaled ? kScaledReach : 0;
  }

  /// Plain coding's; tangent-plane coding has twice as many, its normal axis apart.
  uint32_t contexts(bool tangent_plane) const { return (tangent_plane ? 2 : 1) * kKinds * classes; }
  /// The kind term of axis k's context: the prediction's kind, plus kKinds on the tangent plane's
  /// normal axis (kNoAxis for none), whose residual codes in contexts of its own.
  static uint32_t axis_kind(PredictionKind kind, int k, uint32_t normal_axis) {
    return kind + (uint32_t(k) == normal_axis ? uint32_t{kKinds} : 0u);
  }
  /// Axis k's context, kind being a PredictionKind, plus kKinds for the tangent plane's normal
  /// axis; local, previous_symbol < 128. Up to version 4:
  ///   (kind * activity_classes + min(local, activity_classes - 1)) * previous_classes
  ///   + min(previous_symbol >> 1, previous_classes - 1);
  /// from version 5: kind * classes + min(max(floor(theta / 16), 0), classes - 1), with
  ///   theta = 7 local + previous_symbol + 8 spread_bits[k] + 4 reach_bits + kScaledBias[kind].
  /// One formula computes both (the old terms in sixteenths of a class, never clamped), so that
  /// the decoding loop has no branch on the version.
  uint32_t context(uint32_t kind, uint32_t local, uint32_t previous_symbol, const Prediction& pred,
                   int k) const {
    const int32_t theta = local_term[local & 127] + previous_term[previous_symbol & 127] +
                          spread_weight * int32_t(pred.spread_bits[k]) +
                          reach_weight * int32_t(pred.reach_bits) + bias[kind];
    return kind_term[kind] + uint32_t(std::clamp(theta >> 4, 0, int32_t(classes) - 1));
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
    OSTEON_UNROLL
    for (int k = 0; k < 3; ++k) {
      a[k] = uint64_t(int64_t{n[k]} - o[k]);
      b[k] = uint64_t(int64_t{p[k]} - o[k]);
    }
    normal.xyz[0] += a[1] * b[2] - a[2] * b[1];
    normal.xyz[1] += a[2] * b[0] - a[0] * b[2];
    normal.xyz[2] += a[0] * b[1] - a[1] * b[0];
  }
  uint64_t size[3];
  OSTEON_UNROLL
  for (int k = 0; k < 3; ++k) size[k] = magnitude(normal.xyz[k]);
  if ((size[0] | size[1] | size[2]) != 0) {
    const uint32_t axis = size[1] > size[0] ? 1 : 0;
    normal.axis = size[2] > size[axis] ? 2 : axis;
  }
  return normal;
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

/// A vertex's own prediction residual as its neighbours' curvature step reads it: clamped to
/// +-kResidualReach, so that the step's products fit 64 bits.
constexpr int64_t kResidualReach = int64_t{1} << 20;
inline int32_t fed_residual(int64_t value, int64_t pred) {
  return static_cast<int32_t>(std::clamp(value - pred, -kResidualReach, kResidualReach));
}

/// The curvature step (Refinement) of vertex v, whose normal has an axis (so v has entries), in
/// place: `base` moves along the normal N by `weight` sixteenths of the normal part of m, the
/// rounded mean of the fed residuals (3 per vertex) of v's entries' n and p (entry_mean):
///   n = N >> max(w - 12, 0), w the bit length of its largest |component| (so |n[j]| < 2^12);
///   t = floor(weight (m . n) 2^12 / (n . n));  base[j] += floor((t n[j] + 2^15) / 2^16).
/// |m| <= 2^20 and |n[j]| < 2^12, so |weight (m . n) 2^12| < 2^51 and |t n[j]| < 2^43.
OSTEON_NOINLINE void curvature_step(uint32_t v, const NewestTriangles& nt, const int32_t* fed,
                                    const Normal& normal, int32_t weight, int64_t base[3]) {
  int64_t mean[3];
  entry_mean(v, nt, fed, mean);
  const int width = static_cast<int>(std::bit_width(
      magnitude(normal.xyz[0]) | magnitude(normal.xyz[1]) | magnitude(normal.xyz[2])));
  int64_t n[3];
  int64_t dot = 0, norm = 0;
  OSTEON_UNROLL
  for (int j = 0; j < 3; ++j) {
    n[j] = static_cast<int64_t>(normal.xyz[j]) >> std::max(width - 12, 0);
    dot += mean[j] * n[j];
    norm += n[j] * n[j];
  }
  const int64_t t = floor_div(weight * dot * (int64_t{1} << 12), norm);
  OSTEON_UNROLL
  for (int j = 0; j < 3; ++j) base[j] += (t * n[j] + (int64_t{1} << 15)) >> 16;
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
                                   PredictionMode mode, const TriangleShape& shape,
                                   const Refinement& refine, bool tangent_plane, int64_t lattice,
                                   SymbolDecoder& dec, ByteReader& in, const std::string& source,
                                   QuantizedPositions* q) {
  const uint32_t vertex_count = static_cast<uint32_t>(q->xyz.size() / 3);
  // Written before being read, so not cleared.
  const std::unique_ptr<uint32_t[]> symbols(new uint32_t[vertex_count]);
  // The curvature step's fed residuals, 3 per vertex; only where the stream has one.
  const std::unique_ptr<int32_t[]> fed(
      new int32_t[refine.curvature != 0 ? 3 * size_t{vertex_count} : 0]);
  int32_t* const xyz = q->xyz.data();
  SymbolDecoder::Cursor cursor = dec.cursor();  // in registers through the loop
  uint32_t previous[3] = {0, 0, 0};
  uint32_t mask = 0;  // lattice coding: the axes on lattice planes
  for (uint32_t v = 0; v < vertex_count; ++v) {
    const Prediction pred = predict(v, nt, xyz, symbols.get(), mode, shape, refine.extrapolation);
    // Lattice coding reads the normal, and so do the tangent plane and the curvature step, which
    // lattice coding never has (decode_geometry checks).
    Normal normal;
    if (lattice != 0 || tangent_plane || refine.curvature != 0) {
      normal = parallelogram_normal(v, nt, xyz);
    }
    uint32_t context[3];
    if (lattice == 0) [[likely]] {
      // The tangent plane's axis codes in contexts of its own (none without the plane).
      const uint32_t plane_axis = tangent_plane ? normal.axis : kNoAxis;
      OSTEON_UNROLL
      for (int k = 0; k < 3; ++k) {
        const uint32_t kind = ContextModel::axis_kind(pred.kind, k, plane_axis);
        context[k] = model.context(kind, pred.local[k], previous[k], pred, k);
      }
    } else {
      const uint32_t dominant = normal.axis;
      mask = dec.get(cursor, mask_context(dominant, mask & 7));
      OSTEON_UNROLL
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
      // Up to 32 bits a read (the same bits, in the same order): one read in the loop, not
      // unrolled, keeps this rare path small in the WebAssembly decoder's download.
      int axis = 0, done = 0;
      rest[0] = rest[1] = rest[2] = 0;
#if defined(__clang__)
#pragma clang loop unroll(disable)
#endif
      while (axis < 3) {
        const int count = std::min(static_cast<int>(bits[axis]) - done, 32);
        rest[axis] |= dec.get_bits(cursor, count) << done;
        done += count;
        if (done == static_cast<int>(bits[axis])) {
          ++axis;
          done = 0;
        }
      }
    }
    int64_t r[3];
    int64_t base[3];
    OSTEON_UNROLL
    for (int k = 0; k < 3; ++k) {
      r[k] = unzigzag(kLeadingBits[symbol[k]] | rest[k]);
      base[k] = pred.xyz[k];
    }
    if (normal.axis != kNoAxis && refine.curvature != 0) {
      curvature_step(v, nt, fed.get(), normal, refine.curvature, base);
    }
    if (normal.axis != kNoAxis && tangent_plane) {
      base[normal.axis] = on_tangent_plane(normal, base[normal.axis], r);
    }
    bool in_range = mask < 8;
    OSTEON_UNROLL
    for (int k = 0; k < 3; ++k) {
      int64_t value = base[k] + r[k];
      // On a lattice plane: |r| < 2^34 and lattice <= 2^24, so no overflow before the check.
      if ((mask >> k) & 1) value = (nearest_plane(pred.xyz[k], lattice) + r[k]) * lattice;
      in_range = in_range & (value >= INT32_MIN) & (value <= INT32_MAX);
      xyz[3 * size_t{v} + k] = static_cast<int32_t>(value);
      previous[k] = symbol[k];
      if (refine.curvature != 0) fed[3 * size_t{v} + k] = fed_residual(value, pred.xyz[k]);
    }
    symbols[v] = pack_symbols(symbol[0], symbol[1], symbol[2]);
    if (!cursor.ok || !in_range) [[unlikely]] {
      return invalid_data(source, in.offset(), "geometry: ", "corrupt residual for vertex %", {v});
    }
  }
  dec.resume(cursor);
  return Status::ok_status();
}

// The encoder's last moves of v's prediction `base`, v's coordinates being known, as the decoder
// makes them: with a curvature weight, the curvature step, from the fed residuals of the vertices
// before v (v's own is written here); with the tangent plane, the normal's largest axis moved
// onto the plane. Returns that axis (kNoAxis without the plane).
inline uint32_t refine_prediction(uint32_t v, const NewestTriangles& nt, const int32_t* xyz,
                                  int64_t base[3], bool tangent_plane = true,
                                  int32_t curvature = 0, int32_t* fed = nullptr) {
  if (!tangent_plane && curvature == 0) return kNoAxis;
  for (int k = 0; curvature != 0 && k < 3; ++k) {
    fed[3 * size_t{v} + k] = fed_residual(xyz[3 * size_t{v} + k], base[k]);
  }
  const Normal normal = parallelogram_normal(v, nt, xyz);
  if (normal.axis == kNoAxis) return kNoAxis;
  if (curvature != 0) curvature_step(v, nt, fed, normal, curvature, base);
  if (!tangent_plane) return kNoAxis;
  int64_t r[3];
  for (int k = 0; k < 3; ++k) r[k] = int64_t{xyz[3 * size_t{v} + k]} - base[k];
  base[normal.axis] = on_tangent_plane(normal, base[normal.axis], r);
  return normal.axis;
}

// Plain residuals of one vertex (coordinates `at`) from `base`: hands each axis's (context,
// symbol, z) to `sink`, updates `previous` and returns the packed symbols. normal_axis: the
// tangent plane's, which codes in contexts of its own (kNoAxis for none).
template <class Sink>
inline uint32_t code_plain(const int32_t* at, const int64_t base[3], const Prediction& pred,
                           uint32_t normal_axis, const uint32_t local[3], const ContextModel& model,
                           uint32_t previous[3], Sink& sink) {
  uint32_t symbol[3];
  for (int k = 0; k < 3; ++k) {
    const uint64_t z = zigzag(int64_t{at[k]} - base[k]);
    symbol[k] = residual_symbol(z);
    sink(model.context(ContextModel::axis_kind(pred.kind, k, normal_axis), local[k], previous[k],
                       pred, k),
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
  std::vector<int32_t> fed;       // with a curvature weight: 3 per vertex, the fed residuals
  uint32_t previous[3] = {0, 0, 0};
  uint32_t previous_mask = 0;
};

// The encoder's prediction loop, for both codings as decode_loop reads them (lattice 0: plain
// residuals in the context model's contexts; else a mask symbol, then lattice coding): codes the
// vertices from state->next up to `end`, handing each (context, symbol, z, is_residual) to `sink`
// (the mask symbol has no raw bits).
template <class Sink>
void encode_loop(const NewestTriangles& nt, const QuantizedPositions& q, const ContextModel& model,
                 PredictionMode mode, const TriangleShape& shape, const Refinement& refine,
                 const Placed* placed, bool tangent_plane, int64_t lattice, uint32_t end,
                 LoopState* state, Sink&& sink) {
  assert(state->next <= end && end <= q.xyz.size() / 3);
  assert(refine.curvature == 0 || lattice == 0);
  state->symbols.resize(end);
  if (refine.curvature != 0) state->fed.resize(3 * size_t{end});
  uint32_t* const symbols = state->symbols.data();
  const int32_t* xyz = q.xyz.data();
  uint32_t* const previous = state->previous;
  uint32_t previous_mask = state->previous_mask;
  for (uint32_t v = state->next; v < end; ++v) {
    const Prediction pred = predict(v, nt, xyz, symbols, mode, shape, refine.extrapolation, placed);
    if (lattice == 0) {
      int64_t base[3] = {pred.xyz[0], pred.xyz[1], pred.xyz[2]};
      const uint32_t axis = refine_prediction(v, nt, xyz, base, tangent_plane, refine.curvature,
                                              state->fed.data());
      symbols[v] =
          code_plain(xyz + 3 * size_t{v}, base, pred, axis, pred.local, model, previous, sink);
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
                 PredictionMode mode, const TriangleShape& shape, int32_t extrapolation,
                 const Placed* placed, uint32_t end, LoopState* flat, LoopState* plane,
                 FlatSink&& flat_sink, PlaneSink&& plane_sink) {
  assert(flat->next == plane->next && flat->next <= end && end <= q.xyz.size() / 3);
  flat->symbols.resize(end);
  plane->symbols.resize(end);
  const int32_t* xyz = q.xyz.data();
  for (uint32_t v = flat->next; v < end; ++v) {
    uint32_t plane_local[3];
    const Prediction pred =
        predict<true>(v, nt, xyz, flat->symbols.data(), mode, shape, extrapolation, placed,
                      plane->symbols.data(), plane_local);
    const int32_t* at = xyz + 3 * size_t{v};
    int64_t base[3] = {pred.xyz[0], pred.xyz[1], pred.xyz[2]};
    flat->symbols[v] =
        code_plain(at, base, pred, kNoAxis, pred.local, model, flat->previous, flat_sink);
    const uint32_t axis = refine_prediction(v, nt, xyz, base);
    plane->symbols[v] =
        code_plain(at, base, pred, axis, plane_local, model, plane->previous, plane_sink);
  }
  flat->next = end;
  plane->next = end;
}

// The triangle shape the encoder codes with. A shape's prediction is linear in its weights
// (before rounding), so the midpoints, t and the apex offset of each sampled vertex give every
// shape's: the residuals' bit lengths on kShapeSamples vertices spread over the measured prefix
// (an eighth of it where that is more) estimate a shape's cost. The search starts from the
// parallelogram, version 4's apex blends and the least-squares fit, then moves one weight at a
// time, by 4, 2, then 1 sixteenth, while that lowers the estimate. The apex's share (an integer
// square root and a division per parallelogram, in the decoder too, on the chain from one vertex
// to the next) is kept only where it is estimated to save kApexGain over the best shape without
// it, and a shape at all only where it is estimated to save kShapeGain over the parallelogram.
constexpr uint32_t kShapeSamples = 512;
constexpr double kShapeGain = 0.01;
constexpr double kApexGain = 0.02;
TriangleShape choose_shape(const NewestTriangles& nt, const QuantizedPositions& q, uint32_t end,
                           int64_t lattice) {
  const int32_t* xyz = q.xyz.data();
  // Per sampled vertex and axis: the coordinate, whether it is on a lattice plane, the midpoints'
  // mean and the means of t and of 2d (the offsets at full weight, kMaxShapeWeight sixteenths);
  // per vertex, its parallelograms' normal, for the tangent plane.
  struct Sample {
    int64_t at[3];
    bool on_plane[3];
    double mid[3], offset[2][3];
    double normal[3];
    uint32_t axis;
  };
  std::vector<Sample> samples;
  const uint32_t stride = std::max(1u, end / std::max(kShapeSamples, end / 8));
  for (uint32_t v = 0; v < end; v += stride) {
    Sample x{};
    int count = 0;
    for (uint32_t i = nt.first[v]; i < nt.first[v + 1]; ++i) {
      const NewestTriangle& t = nt.entries[i];
      if (t.o == kNoVertexId) continue;
      const int32_t* n = xyz + 3 * size_t{t.n};
      const int32_t* p = xyz + 3 * size_t{t.p};
      const int32_t* o = xyz + 3 * size_t{t.o};
      int64_t apex[3];
      apex_offset(n, p, o, apex);
      for (int k = 0; k < 3; ++k) {
        x.mid[k] += 0.5 * (double(n[k]) + p[k]);
        x.offset[0][k] += double(n[k]) + p[k] - 2.0 * o[k];
        x.offset[1][k] += double(apex[k]);
      }
      ++count;
    }
    if (count == 0) continue;
    const Normal normal = parallelogram_normal(v, nt, xyz);
    x.axis = normal.axis;
    for (int k = 0; k < 3; ++k) {
      x.at[k] = xyz[3 * size_t{v} + k];
      x.on_plane[k] = lattice != 0 && x.at[k] % lattice == 0;
      x.mid[k] /= count;
      x.offset[0][k] /= count;
      x.offset[1][k] /= count;
      x.normal[k] = double(static_cast<int64_t>(normal.xyz[k]));
    }
    samples.push_back(x);
  }
  // The estimate: the residuals' bit lengths, the smaller of plain residuals and the tangent
  // plane's (which predicts the normal's axis from the other two; not with lattice coding).
  auto estimate = [&](const TriangleShape& w) {
    uint64_t flat = 0, plane = 0;
    for (const Sample& x : samples) {
      int64_t r[3];
      uint64_t bits[3];
      for (int k = 0; k < 3; ++k) {
        const double offset =
            (w.scale * x.offset[0][k] + w.apex * x.offset[1][k]) / kMaxShapeWeight;
        // floor(x + 0.5) by truncating a positive number: std::floor is a library call on
        // x86-64 without SSE4.1. |x| < 2^34 here.
        constexpr double kBias = 1099511627776.0;  // 2^40
        const int64_t pred =
            static_cast<int64_t>(x.mid[k] + offset + 0.5 + kBias) - (int64_t{1} << 40);
        r[k] = x.at[k] - pred;
        bits[k] = bit_length(
            zigzag(x.on_plane[k] ? x.at[k] / lattice - nearest_plane(pred, lattice) : r[k]));
      }
      flat += bits[0] + bits[1] + bits[2];
      if (x.axis == kNoAxis || lattice != 0) {
        plane += bits[0] + bits[1] + bits[2];
        continue;
      }
      const uint32_t d = x.axis, a = d == 0 ? 1 : 0, b = d == 2 ? 1 : 2;
      const double across = r[d] + (x.normal[a] * r[a] + x.normal[b] * r[b]) / x.normal[d];
      plane += bits[a] + bits[b] + bit_length(zigzag(round_half_away(across)));
    }
    return std::min(flat, plane);
  };
  // Each shape's estimate once: the two searches below start from the same shapes and cross
  // each other's paths (on meshes of a few hundred vertices the estimates were a fifth of the
  // encode).
  std::vector<uint64_t> known(size_t{kMaxShapeWeight + 1} * (kMaxShapeWeight + 1), UINT64_MAX);
  auto cost = [&](const TriangleShape& w) {
    uint64_t& memo = known[size_t{uint32_t(w.scale)} * (kMaxShapeWeight + 1) + uint32_t(w.apex)];
    if (memo == UINT64_MAX) memo = estimate(w);
    return memo;
  };
  // Least squares: the weights w minimising sum (at - mid - offset . w / 32)^2.
  double a[2][3] = {};
  for (const Sample& x : samples) {
    for (int k = 0; k < 3; ++k) {
      for (int i = 0; i < 2; ++i) {
        for (int j = 0; j < 2; ++j) a[i][j] += x.offset[i][k] * x.offset[j][k];
        a[i][2] += x.offset[i][k] * (double(x.at[k]) - x.mid[k]);
      }
    }
  }
  auto weight = [](double x) {
    return static_cast<int32_t>(std::clamp(std::lround(x), 0l, long{kMaxShapeWeight}));
  };
  std::vector<TriangleShape> starts;
  for (const uint32_t apex : {2u, 4u, 8u}) starts.push_back(apex_shape(apex));  // version 4's
  const double det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
  if (std::abs(det) > 1e-9 * std::max(1.0, a[0][0] * a[1][1])) {
    starts.push_back({weight(kMaxShapeWeight * (a[0][2] * a[1][1] - a[0][1] * a[1][2]) / det),
                      weight(kMaxShapeWeight * (a[0][0] * a[1][2] - a[1][0] * a[0][2]) / det)});
  }
  if (a[0][0] > 0) starts.push_back({weight(kMaxShapeWeight * a[0][2] / a[0][0]), 0});
  // From the best of `from`, one weight at a time while that lowers the estimate (the apex's
  // weight only where `apex`).
  auto search = [&](const std::vector<TriangleShape>& from, bool apex) {
    std::pair<TriangleShape, uint64_t> best{TriangleShape(), cost(TriangleShape())};
    for (const TriangleShape& w : from) {
      const uint64_t c = cost(w);
      if (c < best.second && (apex || w.apex == 0)) best = {w, c};
    }
    for (const int32_t size : {4, 2, 1}) {  // steps of 4, then 2, then 1 sixteenth
      for (bool moved = true; moved;) {
        moved = false;
        for (int i = 0; i < (apex ? 2 : 1); ++i) {
          for (const int32_t step : {-size, size}) {
            TriangleShape w = best.first;
            int32_t* field = i == 0 ? &w.scale : &w.apex;
            *field += step;
            if (*field < 0 || *field > kMaxShapeWeight) continue;
            const uint64_t c = cost(w);
            if (c < best.second) best = {w, c}, moved = true;
          }
        }
      }
    }
    return best;
  };
  const uint64_t plain = cost(TriangleShape());
  const auto [shape, shape_cost] = search(starts, true);
  const auto [flat, flat_cost] = search(starts, false);
  const bool apex = double(shape_cost) < (1 - kApexGain) * double(flat_cost);
  const TriangleShape best = apex ? shape : flat;
  const uint64_t best_cost = apex ? shape_cost : flat_cost;
  return double(best_cost) <= (1 - kShapeGain) * double(plain) ? best : TriangleShape();
}

// The extrapolation weight (Refinement) the encoder codes with: over the vertices before `end`
// predicted from a decoded neighbour, the even weight whose residuals have the fewest bits (0
// where none has fewer than no step). Such a vertex's prediction reads only decoded coordinates,
// so each weight's residuals are exactly those it would code.
int32_t choose_extrapolation(const NewestTriangles& nt, const QuantizedPositions& q, uint32_t end) {
  constexpr int32_t kWeights = kMaxShapeWeight / 2 + 1;  // 0, 2, .., kMaxShapeWeight
  uint64_t cost[kWeights] = {};
  const int32_t* xyz = q.xyz.data();
  for (uint32_t v = 1; v < end; ++v) {
    const uint32_t u = nt.neighbour[v];
    if (nt.first[v] != nt.first[v + 1] || u == kNoVertexId || nt.first[u] == nt.first[u + 1]) {
      continue;
    }
    int64_t mean[3];  // once, for every weight
    entry_mean(u, nt, xyz, mean);
    for (int32_t i = 0; i < kWeights; ++i) {
      for (int k = 0; k < 3; ++k) {
        const int64_t pred = stepped_out(xyz[3 * size_t{u} + k], mean[k], 2 * i);
        cost[i] += std::bit_width(zigzag(int64_t{xyz[3 * size_t{v} + k]} - pred));
      }
    }
  }
  int32_t best = 0;
  for (int32_t i = 1; i < kWeights; ++i) best = cost[i] < cost[best] ? i : best;
  return 2 * best;
}

// The curvature weight (Refinement) the encoder proposes for the plain coding it keeps (its
// parallelogram mode, with the tangent plane or not): the residuals' bit lengths on
// kCurvatureSamples vertices spread over the first `end` estimate each of kCurvatureWeights; the
// best is proposed only where it is estimated to save kCurvatureGain (encode_geometry then
// measures it). The neighbours' fed residuals are their own predictions' (predict reads only
// decoded coordinates; `symbols`, the kept coding's for the vertices before `end`, only set
// contexts).
constexpr int32_t kCurvatureWeights[] = {0, 4, 8, 12, 16, 20, 24};
constexpr uint32_t kCurvatureSamples = 128;
// With the tangent plane, the estimate promises several times what coding gains (on BodyParts3D's
// bones 1-4% for nothing), so a weight is proposed there only above kCurvaturePlaneGain.
constexpr double kCurvatureGain = 0.01;
constexpr double kCurvaturePlaneGain = 0.04;
int32_t choose_curvature(const NewestTriangles& nt, const QuantizedPositions& q, uint32_t end,
                         PredictionMode mode, const TriangleShape& shape, int32_t extrapolation,
                         bool tangent_plane, const uint32_t* symbols) {
  const int32_t* xyz = q.xyz.data();
  std::vector<int32_t> fed(3 * size_t{end});  // the sampled vertices' neighbours'
  constexpr size_t kWeights = std::size(kCurvatureWeights);
  uint64_t cost[kWeights] = {};
  const uint32_t stride = std::max(1u, end / kCurvatureSamples);
  for (uint32_t v = 0; v < end; v += stride) {
    const Normal normal = parallelogram_normal(v, nt, xyz);
    if (normal.axis == kNoAxis) continue;
    for (uint32_t i = nt.first[v]; i < nt.first[v + 1]; ++i) {
      for (const uint32_t u : {nt.entries[i].n, nt.entries[i].p}) {
        const Prediction at = predict(u, nt, xyz, symbols, mode, shape, extrapolation);
        for (int k = 0; k < 3; ++k) {
          fed[3 * size_t{u} + k] = fed_residual(xyz[3 * size_t{u} + k], at.xyz[k]);
        }
      }
    }
    const Prediction pred = predict(v, nt, xyz, symbols, mode, shape, extrapolation);
    for (size_t w = 0; w < kWeights; ++w) {
      int64_t base[3] = {pred.xyz[0], pred.xyz[1], pred.xyz[2]};
      if (kCurvatureWeights[w] != 0) {
        curvature_step(v, nt, fed.data(), normal, kCurvatureWeights[w], base);
      }
      int64_t r[3];
      for (int k = 0; k < 3; ++k) r[k] = int64_t{xyz[3 * size_t{v} + k]} - base[k];
      const uint32_t d = normal.axis;
      if (tangent_plane) {
        r[d] = int64_t{xyz[3 * size_t{v} + d]} - on_tangent_plane(normal, base[d], r);
      }
      for (int k = 0; k < 3; ++k) cost[w] += std::bit_width(zigzag(r[k]));
    }
  }
  size_t best = 0;
  for (size_t w = 1; w < kWeights; ++w) best = cost[w] < cost[best] ? w : best;
  const double gain = tangent_plane ? kCurvaturePlaneGain : kCurvatureGain;
  return double(cost[best]) <= (1 - gain) * double(cost[0]) ? kCurvatureWeights[best] : 0;
}

}  // namespace

GeometryChoice encode_geometry(const NewestTriangles& nt, const QuantizedPositions& q,
                               uint32_t lattice, std::vector<uint8_t>* out, uint32_t end_state,
                               bool search) {
  const uint32_t vertex_count = static_cast<uint32_t>(q.xyz.size() / 3);
  assert(nt.first.size() == size_t{vertex_count} + 1 && nt.neighbour.size() == vertex_count);
  const ContextModel model(vertex_count, kStreamVersion);
  if (lattice < 2 || lattice > kMaxLattice) lattice = 0;

  // Choose the triangle shape (choose_shape), then measure the codings (both parallelogram
  // modes, with and without the tangent plane, and on the lattice where there is one) with it,
  // and code with the cheapest.
  // They are measured on a prefix in decoding order, a connected patch coded as the whole mesh
  // codes it (its contexts come from vertices before): a quarter of the vertices, at least
  // kMeasuredVertices / 4 and at most kMeasuredVertices. Measuring every vertex took 2-4 passes
  // as long as the coding pass; the prefix codes the codec bench's 74 meshes to the same sizes.
  // Each measured coding queues its symbols as it goes, so the one kept resumes after its
  // prefix instead of predicting it again.
  // Without the search (EncodeOptions::effort 0): one coding, chosen up front (below).
  const uint32_t measured = !search ? 0
                                    : std::min({vertex_count, kMeasuredVertices,
                                                std::max(kMeasuredVertices / 4, vertex_count / 4)});
  const TriangleShape shape = search ? choose_shape(nt, q, measured, lattice) : TriangleShape();
  Refinement refine;  // the curvature weight is chosen for the coding kept, below
  refine.extrapolation = search ? choose_extrapolation(nt, q, measured) : kFastExtrapolation;
  // Each entry's shaped value, once for every coding measured and the one kept, where the apex
  // makes it costly (a square root and a division); without it, computing it again is cheaper
  // than reading it back.
  std::vector<Placed> placed;
  if (shape.apex != 0) {
    placed.resize(nt.entries.size());
    for (size_t i = 0; i < nt.entries.size(); ++i) {
      const NewestTriangle& t = nt.entries[i];
      if (t.o == kNoVertexId) continue;
      shaped_parallelogram(&q.xyz[3 * size_t{t.n}], &q.xyz[3 * size_t{t.p}],
                           &q.xyz[3 * size_t{t.o}], shape, placed[i].data());
    }
  }
  const Placed* const placed_entries = placed.empty() ? nullptr : placed.data();
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
    encode_loop(nt, q, model, PredictionMode(coding.mode % kModes), shape, refine, placed_entries,
                coding.mode >= kModes, coding.lattice, end, &coding.state, sink);
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
  size_t best = 0;  // the coding kept
  if (!search) {
    // Without the search: the mean of the parallelograms, on the tangent plane, or lattice
    // coding where the positions sit on a lattice (what the search keeps on most meshes of each
    // kind).
    if (lattice != 0) {
      add(0, lattice, kLatticeContexts);
    } else {
      add(kModes, 0, model.contexts(true));
    }
  } else {
    for (uint32_t m = 0; m < 2 * kModes; ++m) {
      add(static_cast<uint8_t>(m), 0, model.contexts(m >= kModes));
    }
    for (uint32_t m = 0; lattice != 0 && m < kModes; ++m) {
      add(static_cast<uint8_t>(m), lattice, kLatticeContexts);
    }
    std::vector<uint32_t> histogram;  // one coding's at a time
    // A coding's size from what it queued: all of it, or (plain residuals) its first `entries`
    // symbols, with their raw bits.
    auto estimate = [&](const Coding& c, size_t entries = SIZE_MAX) {
      const uint32_t contexts =
          c.lattice != 0 ? kLatticeContexts : model.contexts(c.mode >= kModes);
      histogram.assign(size_t{contexts} * kResidualSymbols, 0);
      const std::vector<uint32_t>& queued = c.enc.queued();
      const bool all = entries >= queued.size();
      uint64_t raw_bits = 0;
      for (size_t i = 0; i < (all ? queued.size() : entries); ++i) {
        const uint32_t symbol = queued[i] & ((1u << SymbolEncoder::kContextShift) - 1);
        ++histogram[size_t{queued[i] >> SymbolEncoder::kContextShift} * kResidualSymbols + symbol];
        raw_bits += kRawBits[symbol];
      }
      return estimated_bits(histogram, contexts, all ? c.enc.raw_bit_count() : raw_bits);
    };
    // Two stages: the first kFirstStage vertices, where one coding usually leads every other by
    // more than kClearLead already; only a close call is measured on the whole prefix (and that
    // chose as measuring it all did on the codec bench's 74 meshes), and only among the codings
    // within kBehind of the leader after the first stage.
    constexpr uint32_t kFirstStage = 1024;
    constexpr double kClearLead = 1.02;
    constexpr double kBehind = 1.04;
    std::vector<bool> out_of_it(codings.size(), false);
    for (const uint32_t end : {std::min(measured, kFirstStage), measured}) {
      for (uint32_t m = 0; m < kModes; ++m) {  // a parallelogram mode's two plain codings at once
        Coding& flat = codings[m];
        Coding& plane = codings[m + kModes];
        if (out_of_it[m] && out_of_it[m + kModes]) continue;
        encode_pair(nt, q, model, PredictionMode(m), shape, refine.extrapolation, placed_entries,
                    end, &flat.state, &plane.state, queue(flat.enc), queue(plane.enc));
      }
      for (size_t i = 2 * kModes; i < codings.size(); ++i) {
        if (!out_of_it[i]) run(codings[i], end, queue(codings[i].enc));
      }
      best = 0;
      while (out_of_it[best]) ++best;
      for (size_t i = 0; i < codings.size(); ++i) {
        if (out_of_it[i]) continue;
        codings[i].bits = estimate(codings[i]);
        if (codings[i].bits < codings[best].bits) best = i;  // of equals, the first
      }
      bool clear = true;
      for (size_t i = 0; i < codings.size(); ++i) {
        if (out_of_it[i] || i == best) continue;
        if (codings[i].bits <= codings[best].bits * kClearLead) clear = false;
        if (codings[i].bits > codings[best].bits * kBehind) out_of_it[i] = true;
      }
      if (clear) break;
    }
    // The curvature step, for a plain coding: a weight its estimate proposes is measured, on the
    // first kFirstStage vertices (the kept coding again, with it, against the kept coding's own
    // first symbols), and kept only if that measures smaller: the estimate proposes weights on
    // meshes where coding gains nothing. A kept weight's coding resumes from there.
    if (codings[best].lattice == 0) {
      const uint8_t mode = codings[best].mode;
      const uint32_t end = std::min(kFirstStage, codings[best].state.next);
      refine.curvature = choose_curvature(
          nt, q, codings[best].state.next, PredictionMode(mode % kModes), shape,
          refine.extrapolation, mode >= kModes, codings[best].state.symbols.data());
      if (refine.curvature != 0) {
        add(mode, 0, model.contexts(mode >= kModes));
        Coding& with = codings.back();
        run(with, end, queue(with.enc));
        if (estimate(with, 3 * size_t{end}) < estimate(codings[best], 3 * size_t{end})) {
          best = codings.size() - 1;
        } else {
          refine.curvature = 0;
        }
      }
    }
  }
  Coding& kept = codings[best];

  const bool shaped = !shape.parallelogram();
  GeometryChoice choice;
  choice.mode = static_cast<uint8_t>(kept.mode | (shaped ? kShapeFlag : 0) |
                                     (refine.none() ? 0 : kRefineFlag));
  choice.shape_scale = shape.scale;
  choice.shape_apex = shape.apex;
  choice.extrapolation = refine.extrapolation;
  choice.curvature = refine.curvature;
  out->push_back(choice.mode);
  if (shaped) {
    out->push_back(static_cast<uint8_t>(shape.scale));
    out->push_back(static_cast<uint8_t>(shape.apex));
  }
  if (!refine.none()) {
    out->push_back(static_cast<uint8_t>(refine.extrapolation));
    out->push_back(static_cast<uint8_t>(refine.curvature));
  }
  ByteWriter(out).write_varint(kept.lattice);
  kept.enc.reserve(size_t{vertex_count - kept.state.next} * symbols_per_vertex(kept.lattice));
  run(kept, vertex_count, queue(kept.enc));
  for (const Coding& coding : codings) choice.predicted += coding.state.next;
  choice.first_state = kept.enc.append_to(out, end_state, /*chained=*/true);
  return choice;
}

OSTEON_COLD_FUNCTION Result<QuantizedPositions> decode_geometry(
    ByteReader& in, const NewestTriangles& nt, uint32_t vertex_count, uint8_t version,
    const std::string& source, uint32_t* chain, bool more) {
  if (nt.first.size() != size_t{vertex_count} + 1 || nt.neighbour.size() != vertex_count) {
    return error(ErrorCode::kInvalidArgument, source,
                 message("geometry: the connectivity does not have % vertices", {vertex_count}));
  }
  uint8_t mode = 0;
  bool known = in.read_le(&mode);
  const uint32_t high = mode >> kApexShift;
  mode &= (1u << kApexShift) - 1;
  TriangleShape shape;
  Refinement refine;
  if (version == 4) {
    shape = apex_shape(high);
    known = known && high < kApexWeights;
  } else {
    // From version 5: the shape's flag; from version 6, the refinements' too.
    const uint32_t flags = (version >= 6   ? kShapeFlag | kRefineFlag
                            : version == 5 ? kShapeFlag
                                           : 0);
    known = known && (high & ~(flags >> kApexShift)) == 0;
    uint8_t w[4] = {16, 0, 0, 0};
    for (int i = 0; i < 4; ++i) {
      if ((high >> (i / 2)) & 1) known = known && in.read_le(&w[i]) && w[i] <= kMaxShapeWeight;
    }
    shape = {w[0], w[1]};
    refine = {w[2], w[3]};
  }
  if (!known || mode >= (version >= 3 ? 2 * kModes : kModes)) {
    return invalid_data(source, in.offset(), "geometry: ", "unknown prediction mode");
  }
  uint64_t lattice = 0;  // version 2: the lattice period, 0 for none
  if (version >= 2 && (!in.read_varint(&lattice) || lattice == 1 || lattice > kMaxLattice ||
                       (lattice != 0 && (mode >= kModes || refine.curvature != 0)))) {
    return invalid_data(source, in.offset(), "geometry: ", "bad lattice period");
  }
  const ContextModel model(vertex_count, version);
  SymbolDecoder dec;
  const uint64_t symbols = uint64_t{symbols_per_vertex(lattice)} * vertex_count;
  OSTEON_RETURN_IF_ERROR(dec.init(in, kResidualSymbols,
                                  lattice != 0 ? kLatticeContexts : model.contexts(mode >= kModes),
                                  {version, symbols, *chain, more}, source, "geometry"));
  if (dec.symbols_left() != symbols) {
    return invalid_data(source, in.offset(), "geometry: ", "% residual symbols for % vertices",
                        {dec.symbols_left(), vertex_count});
  }
  QuantizedPositions q;
  q.xyz.resize(size_t{vertex_count} * 3);
  OSTEON_RETURN_IF_ERROR(decode_loop(nt, model, PredictionMode(mode % kModes), shape, refine,
                                     mode >= kModes, int64_t(lattice), dec, in, source, &q));
  OSTEON_RETURN_IF_ERROR(dec.finish(source, "geometry"));
  *chain = dec.last_state();
  return q;
}

}  // namespace osteon::detail
