// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <vector>

#include "bench_markdown.hpp"
#include "core/byte_io.hpp"
#include "codec/entropy.hpp"

// Decoding throughput of the symbol coder (src/codec/entropy.cpp) on two synthetic streams shaped like
// the codec's: Edgebreaker-like CLERS symbols with the previous symbol as context, and
// geometry-like residual buckets (24 symbols, 6 contexts) with a raw bit stream of mantissas.
// Built with the other benchmarks (target entropy_bench). Prints symbols/s (best of 15) and
// bits/symbol against the empirical conditional entropy.

namespace {

using osteon::ByteReader;
using osteon::detail::SymbolDecoder;
using osteon::detail::SymbolEncoder;
/// The best of 15 decodes of `bytes` (alphabet and contexts as encoded), in seconds of thread
/// CPU time: init, `decode_all(decoder)` reading every symbol, finish. Aborts on a decoding error.
template <class DecodeAll>
double best_decode(const std::vector<uint8_t>& bytes, uint32_t alphabet, uint32_t contexts,
                   uint64_t symbols, const char* section, DecodeAll&& decode_all) {
  double best = 1e9;
  for (int run = 0; run < 15; ++run) {
    const double t0 = osteon_bench::thread_seconds();
    ByteReader in(bytes.data(), bytes.size());
    SymbolDecoder dec;
    const osteon::detail::SectionLayout layout{osteon::detail::kCompactSectionVersion, symbols};
    if (!dec.init(in, alphabet, contexts, layout, "bench", section).ok()) std::abort();
    decode_all(dec);
    if (!dec.finish("bench", section).ok()) std::abort();
    best = std::min(best, osteon_bench::thread_seconds() - t0);
  }
  return best;
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
  const double t_enc = osteon_bench::thread_seconds();
  std::vector<uint8_t> bytes;
  enc.append_to(&bytes);
  const double encode_s = osteon_bench::thread_seconds() - t_enc;

  uint64_t check = 0;
  const double best = best_decode(bytes, 5, 5, n, "connectivity", [&](SymbolDecoder& dec) {
    uint32_t context = 0;
    for (size_t i = 0; i < n; ++i) {
      context = dec.get(context);
      check += context;
    }
  });
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
  uint64_t check = 0;
  const double best = best_decode(bytes, 24, 6, n, "geometry", [&](SymbolDecoder& dec) {
    uint32_t ctx = 0;
    for (size_t i = 0; i < n; ++i) {
      const uint32_t bucket = dec.get(ctx);
      check += dec.get_bits(static_cast<int>(bucket));
      ctx = std::min<uint32_t>(bucket, 5);
    }
  });
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
