// SPDX-License-Identifier: Apache-2.0
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <vector>

#include "byte_io.hpp"
#include "entropy.hpp"

// Decoding throughput of the symbol coder (src/entropy.cpp) on two synthetic streams shaped like
// the codec's: Edgebreaker-like CLERS symbols with the previous symbol as context, and
// geometry-like residual buckets (24 symbols, 6 contexts) with a raw bit stream of mantissas.
// Not built by CMake: g++ -O2 -std=c++20 -DNDEBUG -Isrc -Iinclude bench/entropy_bench.cpp
// src/entropy.cpp src/status.cpp. Prints symbols/s (best of 15) and bits/symbol against the
// empirical conditional entropy.

namespace {

using osteon::ByteReader;
using osteon::detail::SymbolDecoder;
using osteon::detail::SymbolEncoder;
// Thread CPU time, so that other processes on a busy machine do not count (the machine this was
// written on has 2 cores shared by several builds).
struct Clock {
  using time_point = double;
  static double now() {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
  }
};

double seconds_since(double t0) {
  return Clock::now() - t0;
}

double entropy_bits(const std::vector<std::vector<uint64_t>>& counts) {
  double bits = 0;
  for (const auto& row : counts) {
    uint64_t total = 0;
    for (uint64_t c : row) total += c;
    for (uint64_t c : row) {
      if (c > 0) bits -= static_cast<double>(c) * std::log2(static_cast<double>(c) / total);
    }
  }
  return bits;
}

void report(const char* name, size_t symbols, size_t bytes, double entropy, double best) {
  std::printf(
      "%-10s %9zu symbols  %8zu bytes  %.3f bits/symbol (entropy %.3f, %+.2f%%)  "
      "decode %.2f ms = %.0f M symbols/s\n",
      name, symbols, bytes, 8.0 * bytes / symbols, entropy / symbols,
      100 * (8.0 * bytes / entropy - 1), best * 1e3, symbols / best / 1e6);
}

void connectivity_like(size_t n) {
  // P(next | previous) over C L E R S; C and R dominate as on a typical closed mesh.
  const double p[5][5] = {{0.45, 0.05, 0.02, 0.40, 0.08},
                          {0.60, 0.05, 0.05, 0.25, 0.05},
                          {0.70, 0.05, 0.01, 0.20, 0.04},
                          {0.55, 0.04, 0.03, 0.33, 0.05},
                          {0.50, 0.10, 0.05, 0.30, 0.05}};
  std::mt19937 rng(1);
  std::vector<std::discrete_distribution<uint32_t>> next;
  for (const auto& row : p) next.emplace_back(std::begin(row), std::end(row));
  SymbolEncoder enc(5, 5);
  std::vector<std::vector<uint64_t>> counts(5, std::vector<uint64_t>(5, 0));
  uint32_t previous = 0;
  for (size_t i = 0; i < n; ++i) {
    const uint32_t s = next[previous](rng);
    enc.put(previous, s);
    ++counts[previous][s];
    previous = s;
  }
  const Clock::time_point t_enc = Clock::now();
  std::vector<uint8_t> bytes;
  enc.append_to(&bytes);
  const double encode_s = seconds_since(t_enc);

  double best = 1e9;
  uint64_t check = 0;
  for (int run = 0; run < 15; ++run) {
    const Clock::time_point t0 = Clock::now();
    ByteReader in(bytes.data(), bytes.size());
    SymbolDecoder dec;
    if (!dec.init(in, 5, 5, "bench", "connectivity").ok()) std::abort();
    uint32_t context = 0;
    for (size_t i = 0; i < n; ++i) {
      context = dec.get(context);
      check += context;
    }
    if (!dec.finish("bench", "connectivity").ok()) std::abort();
    best = std::min(best, seconds_since(t0));
  }
  report("CLERS", n, bytes.size(), entropy_bits(counts), best);
  std::printf("           encode %.2f ms (checksum %llu)\n", encode_s * 1e3,
              static_cast<unsigned long long>(check));
}

void geometry_like(size_t n) {
  // Residual magnitude buckets (bit length of |r|, 0..23) and their mantissa + sign as raw bits;
  // the context is the bucket of the previous residual (clamped to 0..5).
  std::mt19937 rng(2);
  std::normal_distribution<double> residual(0, 6);
  SymbolEncoder enc(24, 6);
  std::vector<std::vector<uint64_t>> counts(6, std::vector<uint64_t>(24, 0));
  uint32_t context = 0;
  uint64_t raw_bits = 0;
  for (size_t i = 0; i < n; ++i) {
    const int32_t r = static_cast<int32_t>(std::lround(residual(rng) * (1 + context)));
    const uint32_t magnitude = static_cast<uint32_t>(r < 0 ? -r : r);
    const uint32_t bucket = static_cast<uint32_t>(std::bit_width(magnitude));
    enc.put(context, bucket);
    ++counts[context][bucket];
    if (bucket > 0) {
      enc.put_bits((magnitude << 1 | (r < 0 ? 1 : 0)) & ((1u << bucket) - 1),
                   static_cast<int>(bucket));
      raw_bits += bucket;
    }
    context = std::min<uint32_t>(bucket, 5);
  }
  std::vector<uint8_t> bytes;
  enc.append_to(&bytes);
  double best = 1e9;
  uint64_t check = 0;
  for (int run = 0; run < 15; ++run) {
    const Clock::time_point t0 = Clock::now();
    ByteReader in(bytes.data(), bytes.size());
    SymbolDecoder dec;
    if (!dec.init(in, 24, 6, "bench", "geometry").ok()) std::abort();
    uint32_t ctx = 0;
    for (size_t i = 0; i < n; ++i) {
      const uint32_t bucket = dec.get(ctx);
      check += dec.get_bits(static_cast<int>(bucket));
      ctx = std::min<uint32_t>(bucket, 5);
    }
    if (!dec.finish("bench", "geometry").ok()) std::abort();
    best = std::min(best, seconds_since(t0));
  }
  report("residuals", n, bytes.size(), entropy_bits(counts) + static_cast<double>(raw_bits), best);
  std::printf("           (raw bits included in bytes and entropy; checksum %llu)\n",
              static_cast<unsigned long long>(check));
}

}  // namespace

int main() {
  connectivity_like(5000000);
  geometry_like(3000000);
  return 0;
}
