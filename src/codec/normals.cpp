// SPDX-License-Identifier: Apache-2.0
#include "codec/normals.hpp"

#include <cmath>

#include "codec/code_placement.hpp"
#include "codec/entropy.hpp"
#include "codec/residual.hpp"

// Based on: octahedral normal vectors (Meyer et al. 2010, "On floating-point normal vectors";
// Cigolle et al. 2014, "A survey of efficient representations for independent unit vectors"),
// predicted from the decoded geometry as Draco's "geometric normal" predictor does: the decoder
// already has the surface, so only the normal's deviation from the surface's own normal is sent.
// All prediction arithmetic is in double on integer grid coordinates, so every platform (native
// and WebAssembly) computes the same prediction.

namespace osteon::detail {

namespace {

struct Octahedral {
  uint32_t u, v;
};

Octahedral octahedral_encode(double x, double y, double z, int bits) {
  double l1 = std::fabs(x) + std::fabs(y) + std::fabs(z);
  if (!(l1 > 0)) {
    x = 0;
    y = 0;
    z = 1;
    l1 = 1;
  }
  x /= l1;
  y /= l1;
  if (z < 0) {
    double ox = (1 - std::fabs(y)) * (x >= 0 ? 1 : -1);
    double oy = (1 - std::fabs(x)) * (y >= 0 ? 1 : -1);
    x = ox;
    y = oy;
  }
  const double scale = double((1u << bits) - 1);
  return {uint32_t(round_half_away((x * 0.5 + 0.5) * scale)),
          uint32_t(round_half_away((y * 0.5 + 0.5) * scale))};
}

// The area-weighted normal of every vertex of the quantized surface, octahedrally coded.
std::vector<Octahedral> predictions(const std::vector<uint32_t>& indices,
                                    const QuantizedPositions& q, int bits) {
  size_t vertex_count = q.xyz.size() / 3;
  std::vector<double> sum(vertex_count * 3, 0.0);
  for (size_t t = 0; t + 2 < indices.size(); t += 3) {
    const int32_t* a = &q.xyz[3 * size_t{indices[t]}];
    const int32_t* b = &q.xyz[3 * size_t{indices[t + 1]}];
    const int32_t* c = &q.xyz[3 * size_t{indices[t + 2]}];
    const Vec3d u{double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
    const Vec3d v{double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
    const Vec3d n = cross(u, v);
    OSTEON_UNROLL
    for (int k = 0; k < 3; ++k) {
      double* s = &sum[3 * size_t{indices[t + k]}];
      s[0] += n.x;
      s[1] += n.y;
      s[2] += n.z;
    }
  }
  std::vector<Octahedral> out(vertex_count);
  for (size_t v = 0; v < vertex_count; ++v) {
    out[v] = octahedral_encode(sum[3 * v], sum[3 * v + 1], sum[3 * v + 2], bits);
  }
  return out;
}

// The residual between two octahedral codes, wrapped into [-2^(bits-1), 2^(bits-1)).
int64_t wrap(int64_t d, int bits) {
  const int64_t range = int64_t{1} << bits;
  d &= range - 1;
  return d >= range / 2 ? d - range : d;
}

}  // namespace

Vec3 octahedral_decode(uint32_t u, uint32_t v, int bits) {
  const double scale = double((1u << bits) - 1);
  double x = double(u) / scale * 2 - 1, y = double(v) / scale * 2 - 1;
  double z = 1 - std::fabs(x) - std::fabs(y);
  if (z < 0) {
    double ox = (1 - std::fabs(y)) * (x >= 0 ? 1 : -1);
    double oy = (1 - std::fabs(x)) * (y >= 0 ? 1 : -1);
    x = ox;
    y = oy;
  }
  double length = std::sqrt(x * x + y * y + z * z);
  return {float(x / length), float(y / length), float(z / length)};
}

uint32_t encode_normals(const std::vector<uint32_t>& indices, const QuantizedPositions& q,
                        const std::vector<Vec3>& normals, int bits, std::vector<uint8_t>* out) {
  out->push_back(uint8_t(bits));
  std::vector<Octahedral> predicted = predictions(indices, q, bits);
  SymbolEncoder enc(kResidualSymbols, 2);
  for (size_t v = 0; v < normals.size(); ++v) {
    const Vec3& n = normals[v];
    Octahedral code = octahedral_encode(n.x, n.y, n.z, bits);
    int64_t d[2] = {wrap(int64_t{code.u} - predicted[v].u, bits),
                    wrap(int64_t{code.v} - predicted[v].v, bits)};
    for (int k = 0; k < 2; ++k) {
      uint64_t z = zigzag(d[k]);
      uint32_t symbol = residual_symbol(z);
      enc.put(uint32_t(k), symbol);
      put_residual_bits(enc, symbol, z);
    }
  }
  return enc.append_to(out, kRansLow, /*chained=*/true);
}

OSTEON_COLD_FUNCTION Result<std::vector<Vec3>> decode_normals(
    ByteReader& in, const std::vector<uint32_t>& indices, const QuantizedPositions& q,
    uint8_t version, const std::string& source, uint32_t first_state) {
  uint8_t bits = 0;
  if (!in.read_le(&bits) || bits < 8 || bits > 16) {
    return invalid_data(source, in.offset(), "normals: ", "bits per component must be 8..16");
  }
  std::vector<Octahedral> predicted = predictions(indices, q, bits);
  SymbolDecoder dec;
  OSTEON_RETURN_IF_ERROR(dec.init(in, kResidualSymbols, 2,
                                  {version, 2 * uint64_t{predicted.size()}, first_state}, source,
                                  "normals"));
  std::vector<Vec3> normals(predicted.size());
  const int64_t mask = (int64_t{1} << bits) - 1;
  for (size_t v = 0; v < normals.size(); ++v) {
    int64_t code[2] = {predicted[v].u, predicted[v].v};
    OSTEON_UNROLL
    for (int k = 0; k < 2; ++k) {
      uint32_t symbol = dec.get(uint32_t(k));
      int64_t d = unzigzag(get_residual(dec, symbol));
      code[k] = (code[k] + d) & mask;
    }
    if (!dec.ok()) {
      return invalid_data(source, in.offset(), "normals: ", "corrupt residual for vertex %", {v});
    }
    normals[v] = octahedral_decode(uint32_t(code[0]), uint32_t(code[1]), bits);
  }
  OSTEON_RETURN_IF_ERROR(dec.finish(source, "normals"));
  return normals;
}

}  // namespace osteon::detail
