// SPDX-License-Identifier: Apache-2.0
#include "codec/entropy.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "core/byte_io.hpp"
#include "osteon/status.hpp"

// Based on: J. Duda, "Asymmetric numeral systems: entropy coding combining speed of Huffman coding
// with compression rate of arithmetic coding", arXiv:1311.2540 (2013), and F. Giesen's ryg_rans
// (byte-wise 32-bit rANS: state in [2^23, 2^31), 12-bit probabilities, encoding in reverse so the
// decoder reads forwards). Tables use Elias gamma and exponential-Golomb codes (Teuhola 1978).
//
// The section layout is in docs/FORMAT.md ("Symbol section"). In short: the tables carry a weight
// per present symbol (its count, or its count shifted right when that codes smaller), and both
// sides scale the weights to 12-bit frequencies with the same integer-only function, normalize()
// below. Counts of a small mesh are small numbers, so this is cheaper than sending frequencies.
// Contexts may share a table: the encoder merges contexts whose own tables would cost more than
// sharing loses (group_contexts()), which keeps many-context models affordable on small meshes.

namespace osteon::detail {
namespace {

constexpr uint32_t kProbBits = 12;
constexpr uint32_t kProbScale = 1u << kProbBits;  // frequencies of a context sum to this
constexpr uint64_t kMaxSymbols = 0xffffffffu;
constexpr int kMaxGammaZeros = 32;   // gamma-coded values are < 2^33
constexpr int kMaxGolombOrder = 31;  // so (2^33 - 1) << k fits in 64 bits
// The symbols are coded by kStates interleaved rANS states: symbol i by state i mod kStates. From
// stream version 8 a section of fewer than kShortSection symbols has one state (its flush costs 4
// bytes, not 12, on a bone's coarsest level of a few hundred symbols).
constexpr uint32_t kStates = 3;
constexpr uint64_t kShortSection = 4096;
constexpr uint32_t states_for(uint64_t symbols) {
  return symbols < kShortSection ? 1 : kStates;
}
// A decode step in a context of two or more symbols (every frequency <= 4095) shrinks its state
// by a factor <= 1 - 2^-12 (plus 1); a byte read grows it by < 2^8. Starting below 2^31 and
// ending at >= 2^23, a state that reads R renormalisation bytes decodes fewer than
// 22,720 * (R + 1) such symbols, so kStates states reading R bytes in all fewer than
// 22,720 * (R + kStates); kSymbolsPerByte rounds that up.
constexpr uint64_t kSymbolsPerByte = 8 * kProbScale;

// ---- bit-level codes for the tables ----------------------------------------------------------

/// Bits written LSB-first into bytes (bit i of the stream is bit i % 8 of byte i / 8).
class BitWriter {
 public:
  void put(uint64_t value, int count) {
    for (int i = 0; i < count; ++i, ++count_) {
      if ((count_ & 7) == 0) bytes_.push_back(0);
      bytes_.back() |= static_cast<uint8_t>(((value >> i) & 1) << (count_ & 7));
    }
  }
  /// Elias gamma, value >= 1: floor(log2 v) zeros, a one, then v's bits below its top bit.
  void gamma(uint64_t value) {
    const int width = std::bit_width(value);
    put(0, width - 1);
    put(1, 1);
    put(value, width - 1);
  }
  /// Exponential-Golomb of order k: gamma((v >> k) + 1), then the low k bits of v.
  void exp_golomb(uint64_t value, int k) {
    gamma((value >> k) + 1);
    put(value, k);
  }
  const std::vector<uint8_t>& bytes() const { return bytes_; }

 private:
  std::vector<uint8_t> bytes_;
  uint64_t count_ = 0;
};

int gamma_bits(uint64_t value) {
  return 2 * std::bit_width(value) - 1;
}
int exp_golomb_bits(uint64_t value, int k) {
  return gamma_bits((value >> k) + 1) + k;
}

/// Reads what BitWriter wrote; every read fails (returns false) past the end instead of reading.
class BitReader {
 public:
  BitReader(const uint8_t* data, size_t size) : data_(data), size_bits_(uint64_t{size} * 8) {}

  bool get(int count, uint64_t* out) {
    if (static_cast<uint64_t>(count) > size_bits_ - pos_) return false;
    uint64_t value = 0;
    for (int i = 0; i < count; ++i, ++pos_) {
      value |= static_cast<uint64_t>((data_[pos_ >> 3] >> (pos_ & 7)) & 1) << i;
    }
    *out = value;
    return true;
  }
  bool gamma(uint64_t* out) {
    int zeros = 0;
    for (;;) {
      uint64_t bit = 0;
      if (!get(1, &bit)) return false;
      if (bit == 1) break;
      if (++zeros > kMaxGammaZeros) return false;
    }
    uint64_t low = 0;
    if (!get(zeros, &low)) return false;
    *out = (uint64_t{1} << zeros) | low;
    return true;
  }
  bool exp_golomb(int k, uint64_t* out) {
    uint64_t high = 0;
    uint64_t low = 0;
    if (!gamma(&high) || !get(k, &low)) return false;
    *out = ((high - 1) << k) | low;
    return true;
  }
  /// Whole bytes touched so far, and whether the unused bits of the last one are zero.
  size_t bytes_used() const { return static_cast<size_t>((pos_ + 7) / 8); }
  size_t byte_offset() const { return static_cast<size_t>(pos_ / 8); }
  bool padding_is_zero() const { return (pos_ & 7) == 0 || (data_[pos_ >> 3] >> (pos_ & 7)) == 0; }

 private:
  const uint8_t* data_;
  uint64_t size_bits_;
  uint64_t pos_ = 0;
};

// ---- frequency tables ------------------------------------------------------------------------

/// A table as the table block carries it: the present symbols (increasing) and a weight >= 1 for
/// each. Frequencies are normalize(weights): the weights are the symbol counts of the contexts
/// sharing the table, or the counts shifted right where the table would cost more than the
/// precision is worth.
struct WeightTable {
  std::vector<uint32_t> symbols;
  std::vector<uint32_t> weights;
};

/// Scales `weights` (1..kProbScale of them, each >= 1) to frequencies >= 1 that sum to exactly
/// kProbScale, minimising the coded size sum(w * log2(kProbScale / f)): rounds the proportional
/// share, then moves single slots greedily, taking from the symbol that loses least
/// (w * log(f / (f-1)) ~ w / (f - 1/2)) or giving to the one that gains most (w / (f + 1/2)).
/// Integer arithmetic only, so the encoder and every decoder (native or WebAssembly) compute the
/// same table. A single symbol gets all kProbScale slots and then costs no bits.
/// O(n * d) for n weights whose rounded shares miss kProbScale by d (both at most 68 here).
OSTEON_COLD_FUNCTION std::vector<uint32_t> normalize(const std::vector<uint32_t>& weights) {
  const size_t n = weights.size();
  assert(n >= 1 && n <= kProbScale);
  std::vector<uint32_t> freq(n, kProbScale);
  if (n == 1) return freq;
  uint64_t total = 0;  // < 2^44
  for (uint32_t w : weights) total += w;
  uint64_t sum = 0;
  for (size_t i = 0; i < n; ++i) {
    freq[i] = static_cast<uint32_t>(
        std::max<uint64_t>(1, (uint64_t{weights[i]} * kProbScale + total / 2) / total));
    sum += freq[i];
  }
  // Products stay below 2^32 * 2^14: no overflow. Ties go to the lower symbol. Each slot moved
  // is found by a scan: alphabets have at most 68 symbols, and a heap costs the WebAssembly
  // decoder's download more than the scans cost its time.
  if (sum > kProbScale) {
    auto costs_more = [&](size_t a, size_t b) {  // taking a slot from a loses more than from b
      const uint64_t lhs = uint64_t{weights[a]} * (2 * freq[b] - 1);
      const uint64_t rhs = uint64_t{weights[b]} * (2 * freq[a] - 1);
      return lhs != rhs ? lhs > rhs : a > b;
    };
    for (; sum > kProbScale; --sum) {  // n <= kProbScale: some freq > 1 remains
      size_t cheapest = n;
      for (size_t i = 0; i < n; ++i) {
        if (freq[i] > 1 && (cheapest == n || costs_more(cheapest, i))) cheapest = i;
      }
      --freq[cheapest];
    }
  } else {
    auto gains_less = [&](size_t a, size_t b) {  // a slot given to a gains less than to b
      const uint64_t lhs = uint64_t{weights[a]} * (2 * freq[b] + 1);
      const uint64_t rhs = uint64_t{weights[b]} * (2 * freq[a] + 1);
      return lhs != rhs ? lhs < rhs : a > b;
    };
    for (; sum < kProbScale; ++sum) {
      size_t most = 0;
      for (size_t i = 1; i < n; ++i) {
        if (gains_less(most, i)) most = i;
      }
      ++freq[most];
    }
  }
  return freq;
}

/// How a model is written (FORMAT.md): presence dense (a weight for every symbol up to the last
/// present one, 0 = absent) or sparse (the present symbols' gaps), and the weights'
/// exponential-Golomb order.
struct ModelCode {
  bool dense = false;
  int order = 0;
};

/// Bits write_model spends on `model`.
uint64_t model_bits(const WeightTable& model, ModelCode code) {
  const size_t n = model.symbols.size();
  uint64_t bits = 1;
  if (code.dense) {
    const uint32_t top = model.symbols.back();
    bits += gamma_bits(top + 1) + gamma_bits(code.order + 1);
    bits += uint64_t{top + 1 - n} * exp_golomb_bits(0, code.order);
    for (uint32_t w : model.weights) bits += exp_golomb_bits(w, code.order);
  } else {
    bits += gamma_bits(n);
    uint32_t previous = ~0u;
    for (uint32_t s : model.symbols) {
      bits += gamma_bits(s - previous);
      previous = s;
    }
    if (n > 1) {
      bits += gamma_bits(code.order + 1);
      for (uint32_t w : model.weights) bits += exp_golomb_bits(w - 1, code.order);
    }
  }
  return bits;
}

void write_model(BitWriter* out, const WeightTable& model, ModelCode code) {
  const size_t n = model.symbols.size();
  out->put(code.dense ? 0 : 1, 1);
  if (code.dense) {
    out->gamma(model.symbols.back() + 1);
    out->gamma(static_cast<uint64_t>(code.order) + 1);
    for (size_t i = 0, s = 0; i < n; ++s) {
      if (model.symbols[i] == s) {
        out->exp_golomb(model.weights[i++], code.order);
      } else {
        out->exp_golomb(0, code.order);
      }
    }
  } else {
    out->gamma(n);
    uint32_t previous = ~0u;
    for (uint32_t s : model.symbols) {
      out->gamma(s - previous);
      previous = s;
    }
    if (n > 1) {
      out->gamma(static_cast<uint64_t>(code.order) + 1);
      for (uint32_t w : model.weights) out->exp_golomb(w - 1, code.order);
    }
  }
}

/// The model of a context whose symbols occurred `counts` times (`alphabet` entries, some > 0)
/// and the way to write it that minimise table bits plus coded bits: weights = counts >> s
/// (rounded, at least 1) for the best s. Small streams keep exact counts where they are small
/// and cheap; large ones drop the precision the 12-bit frequencies cannot use anyway.
std::pair<WeightTable, ModelCode> choose_model(const uint32_t* counts, uint32_t alphabet) {
  WeightTable exact;
  uint32_t largest = 0;
  for (uint32_t s = 0; s < alphabet; ++s) {
    if (counts[s] == 0) continue;
    exact.symbols.push_back(s);
    exact.weights.push_back(counts[s]);
    largest = std::max(largest, counts[s]);
  }
  if (exact.symbols.size() == 1) {  // deterministic: the weight is not written
    exact.weights[0] = 1;
    return {exact, ModelCode{false, 0}};
  }
  std::pair<WeightTable, ModelCode> best;
  double best_bits = INFINITY;
  WeightTable model = exact;
  for (int shift = 0; shift <= static_cast<int>(std::bit_width(largest)); ++shift) {
    uint64_t weight_sum = 0;
    for (size_t i = 0; i < exact.weights.size(); ++i) {
      const uint64_t rounded = (uint64_t{exact.weights[i]} + (uint64_t{1} << shift >> 1)) >> shift;
      model.weights[i] = static_cast<uint32_t>(std::max<uint64_t>(1, rounded));
      weight_sum += model.weights[i];
    }
    const std::vector<uint32_t> freq = normalize(model.weights);
    double coded = 0;
    for (size_t i = 0; i < freq.size(); ++i) {
      coded += exact.weights[i] * std::log2(static_cast<double>(kProbScale) / freq[i]);
    }
    // exp-Golomb is shortest near order log2(mean weight); try the orders around it.
    const int mean_width = std::bit_width(weight_sum / model.weights.size());
    for (int order = std::max(0, mean_width - 3); order <= mean_width + 1; ++order) {
      for (bool dense : {false, true}) {
        const double bits = coded + static_cast<double>(model_bits(model, {dense, order}));
        if (bits < best_bits) {
          best_bits = bits;
          best = {model, ModelCode{dense, order}};
        }
      }
    }
    if (weight_sum == model.weights.size()) break;  // all ones: coarser changes nothing
  }
  return best;
}

/// (symbol, count) pairs of the symbols that occur, by symbol.
using SparseCounts = std::vector<std::pair<uint32_t, uint32_t>>;

/// A rough size of a table plus the symbols it codes: their empirical entropy
/// (total * log2(total) - sum(count * log2(count))), about 2 + log2(1 + count) bits per present
/// symbol for presence and weight, and 8 bits of header. Merging two tables changes only the
/// terms of the totals and of the symbols both have, so what a merge saves is computed from
/// those alone (merge_saving).
class LogTerms {
 public:
  LogTerms() {
    entropy_[0] = 0;  // 0 * log2(0): no symbol, no term
    symbol_[0] = 0;
    for (uint32_t i = 1; i < kSize; ++i) {
      entropy_[i] = entropy_of(i);
      symbol_[i] = symbol_of(i);
    }
  }
  /// c * log2(c), 0 for 0: looked up below kSize (the merging search spent half its time in
  /// log2), computed above.
  double entropy(uint64_t c) const { return c < kSize ? entropy_[c] : entropy_of(c); }
  /// A present symbol's terms: its table bits, 2 + log2(1 + c), less c * log2(c); 0 for an
  /// absent one (c = 0).
  double symbol(uint64_t c) const { return c < kSize ? symbol_[c] : symbol_of(c); }
  /// symbol(c) for c < kSize: a lookup and nothing else, so that a loop of them calls nothing
  /// (a call would spill its accumulator to memory on every step).
  double small_symbol(uint32_t c) const { return symbol_[c]; }

  /// Counts the tables hold: any two merge candidates together (each has under kMergeBelow).
  static constexpr uint32_t kSize = 8192;

 private:
  static double entropy_of(uint64_t c) { return double(c) * std::log2(double(c)); }
  static double symbol_of(uint64_t c) { return 2 + std::log2(1 + double(c)) - entropy_of(c); }

  std::array<double, kSize> entropy_;
  std::array<double, kSize> symbol_;
};

const LogTerms& log_terms() {
  static const LogTerms terms;
  return terms;
}

/// The estimated bits that coding clusters a and b with one table saves, table bits saved less
/// coding bits lost, given their symbol totals, a's counts by symbol (`scattered`, alphabet wide)
/// and b's pairs: only the symbols both have change their terms. A symbol a lacks adds exactly
/// zero, so the loop has no branch on the data: it costs b's pairs and no mispredictions.
double merge_saving(const LogTerms& terms, uint64_t total_a, const uint32_t* scattered,
                    uint64_t total_b, const SparseCounts& b) {
  // Per shared symbol: its table bits saved, less the entropy lost; `term` is LogTerms::symbol,
  // or small_symbol where every count is below kSize.
  auto shared = [&](auto&& term) {
    double sum = 0;
    for (const auto& [symbol, count_b] : b) {
      const uint32_t count_a = scattered[symbol];
      sum += term(count_a) + term(count_b) - term(uint64_t{count_a} + count_b);
    }
    return sum;
  };
  const double saved_by_symbols =
      total_a + total_b < LogTerms::kSize
          ? shared([&](uint64_t c) { return terms.small_symbol(static_cast<uint32_t>(c)); })
          : shared([&](uint64_t c) { return terms.symbol(c); });
  constexpr double kHeaderBits = 8;
  return terms.entropy(total_a) + terms.entropy(total_b) - terms.entropy(total_a + total_b) +
         kHeaderBits + saved_by_symbols;
}

/// The union of a and b, counts added.
SparseCounts merged_counts(const SparseCounts& a, const SparseCounts& b) {
  SparseCounts out;
  out.reserve(a.size() + b.size());
  size_t i = 0;
  size_t j = 0;
  while (i < a.size() || j < b.size()) {
    if (j == b.size() || (i < a.size() && a[i].first < b[j].first)) {
      out.push_back(a[i++]);
    } else if (i == a.size() || b[j].first < a[i].first) {
      out.push_back(b[j++]);
    } else {
      out.emplace_back(a[i].first, a[i].second + b[j].second);
      ++i;
      ++j;
    }
  }
  return out;
}

/// Which table each used context (row of `counts`, `alphabet` wide) codes with: contexts share a
/// table where the table bits saved outweigh the coding loss, which matters for small meshes
/// whose many contexts see a few symbols each. Greedy agglomerative merging on the estimate
/// above, best pair first (of equal pairs, the one of lower indices). Only rows with fewer than
/// kMergeBelow symbols take part, the smallest first, at most kMergeCandidates of them and few
/// enough that m^2 * min(alphabet, present symbols) stays under kMergeWork, which bounds the time;
/// the pairs' savings take m^2 / 2 doubles (at most 1 MiB). Returns a group per row (the row whose
/// counts the group's table uses); rows of a group share a table.
constexpr size_t kMergeCandidates = 512;
constexpr uint64_t kMergeBelow = 4096;
constexpr uint64_t kMergeWork = uint64_t{1} << 21;

std::vector<uint32_t> group_contexts(const std::vector<uint32_t>& counts, uint32_t rows,
                                     uint32_t alphabet) {
  std::vector<uint32_t> group(rows);
  struct Candidate {
    uint64_t symbols;
    uint32_t present;
    uint32_t row;
  };
  std::vector<Candidate> sizes;
  for (uint32_t r = 0; r < rows; ++r) {
    group[r] = r;
    Candidate c{0, 0, r};
    for (uint32_t s = 0; s < alphabet; ++s) {
      c.symbols += counts[size_t{r} * alphabet + s];
      c.present += counts[size_t{r} * alphabet + s] > 0 ? 1 : 0;
    }
    if (c.symbols < kMergeBelow) sizes.push_back(c);
  }
  std::sort(sizes.begin(), sizes.end(), [](const Candidate& a, const Candidate& b) {
    return a.symbols != b.symbols ? a.symbols < b.symbols : a.row < b.row;
  });
  size_t m = 0;
  for (uint64_t present = 0; m < std::min(sizes.size(), kMergeCandidates); ++m) {
    present += sizes[m].present;
    if (uint64_t{m + 1} * (m + 1) * std::min<uint64_t>(alphabet, present) > kMergeWork) break;
  }
  if (m < 2) return group;

  // Each cluster's counts and symbol total. A cluster's pairs are evaluated with its counts
  // scattered by symbol, each pair then costing the other cluster's symbols.
  const LogTerms& terms = log_terms();
  std::vector<SparseCounts> cluster(m);
  std::vector<uint64_t> total(m);
  std::vector<uint8_t> alive(m, 1);
  for (size_t i = 0; i < m; ++i) {
    const uint32_t* row = &counts[size_t{sizes[i].row} * alphabet];
    for (uint32_t s = 0; s < alphabet; ++s) {
      if (row[s] > 0) cluster[i].emplace_back(s, row[s]);
    }
    total[i] = sizes[i].symbols;
  }
  std::vector<uint32_t> scattered(alphabet, 0);
  auto scatter = [&](size_t a, bool on) {
    for (const auto& [symbol, count] : cluster[a]) scattered[symbol] = on ? count : 0;
  };
  // The bits each pair of clusters saves merged (symmetric: kept for a < b), and each cluster's
  // best partner: the most saved, the lower index among equals (none while nothing is saved).
  // Finding the best merge is then a pass over the clusters, and a merge re-evaluates the
  // merged cluster's pairs and re-scans only the clusters whose partner it took.
  constexpr double kReferenceBits = 3;  // a context naming a table defined before it
  constexpr uint32_t kNoPartner = 0xffffffffu;
  std::vector<double> saved(m * (m - 1) / 2);
  auto index = [m](size_t a, size_t b) { return a * (2 * m - a - 1) / 2 + b - a - 1; };  // a < b
  auto pair_saved = [&](size_t a, size_t b) -> double& {
    return a < b ? saved[index(a, b)] : saved[index(b, a)];
  };
  auto evaluate = [&](size_t a, size_t b) {  // a's counts scattered
    pair_saved(a, b) =
        merge_saving(terms, total[a], scattered.data(), total[b], cluster[b]) - kReferenceBits;
  };
  std::vector<double> best(m, 0);
  std::vector<uint32_t> partner(m, kNoPartner);
  auto rescan = [&](size_t i) {
    // A dead cluster counts as saving nothing (a select, not a branch), so only a new best
    // branches; pairs (j, i) for j < i are a column of the triangle, (i, j) for j > i a row.
    double most = 0;
    uint32_t with = kNoPartner;
    auto consider = [&](size_t j, double pair) {
      const double value = alive[j] ? pair : 0.0;
      if (value > most) {
        most = value;
        with = static_cast<uint32_t>(j);
      }
    };
    for (size_t j = 0; j < i; ++j) consider(j, saved[index(j, i)]);
    for (size_t j = i + 1; j < m; ++j) consider(j, saved[index(i, j)]);
    best[i] = most;
    partner[i] = with;
  };
  for (size_t a = 0; a < m; ++a) {
    scatter(a, true);
    for (size_t b = a + 1; b < m; ++b) evaluate(a, b);
    scatter(a, false);
  }
  for (size_t i = 0; i < m; ++i) rescan(i);
  while (true) {
    size_t first = m;
    for (size_t i = 0; i < m; ++i) {
      if (alive[i] && partner[i] != kNoPartner && (first == m || best[i] > best[first])) first = i;
    }
    if (first == m) break;
    const size_t a = std::min<size_t>(first, partner[first]);
    const size_t b = std::max<size_t>(first, partner[first]);
    cluster[a] = merged_counts(cluster[a], cluster[b]);
    cluster[b] = SparseCounts();
    total[a] += total[b];
    alive[b] = 0;
    for (uint32_t& g : group) {
      if (g == sizes[b].row) g = sizes[a].row;
    }
    scatter(a, true);
    for (size_t j = 0; j < m; ++j) {
      if (alive[j] && j != a) evaluate(a, j);
    }
    scatter(a, false);
    rescan(a);
    for (size_t j = 0; j < m; ++j) {
      if (!alive[j] || j == a) continue;
      if (partner[j] == a || partner[j] == b) {
        rescan(j);
      } else if (pair_saved(a, j) > best[j] ||
                 (partner[j] != kNoPartner && pair_saved(a, j) == best[j] && a < partner[j])) {
        best[j] = pair_saved(a, j);
        partner[j] = static_cast<uint32_t>(a);
      }
    }
  }
  return group;
}

constexpr uint32_t kUnusedRow = 0xffffffffu;

/// Completes `t`, whose row[] numbers the `used` rows of `counts` (`alphabet` wide; kUnusedRow
/// for a context that does not occur): groups the rows, adds each row's counts into its group's
/// row, and writes the table block (docs/FORMAT.md, "Symbol section"): tables in context order,
/// each defined where its first context occurs.
void plan_tables(uint32_t used, uint32_t alphabet, std::vector<uint32_t>* counts_in,
                 SymbolPlan* plan) {
  std::vector<uint32_t>& counts = *counts_in;
  SymbolPlan& t = *plan;
  const std::vector<uint32_t>& row = t.row;
  BitWriter block;
  // Contexts that share a table get the sum of their counts; group[row] is the row holding it.
  t.group = group_contexts(counts, used, alphabet);
  for (uint32_t r = 0; r < used; ++r) {
    if (t.group[r] == r) continue;
    for (uint32_t s = 0; s < alphabet; ++s) {
      counts[size_t{t.group[r]} * alphabet + s] += counts[size_t{r} * alphabet + s];
    }
  }
  t.freq.assign(counts.size(), 0);
  t.start.assign(counts.size(), 0);
  std::vector<uint32_t> table_index(used, kUnusedRow);  // per group row, in definition order
  uint32_t tables = 0;
  block.gamma(used);
  uint32_t previous = ~0u;
  for (uint32_t c = 0; c < row.size(); ++c) {
    if (row[c] == kUnusedRow) continue;
    block.gamma(c - previous);
    previous = c;
    const uint32_t g = t.group[row[c]];
    if (table_index[g] != kUnusedRow) {  // a table defined for an earlier context
      block.gamma(table_index[g] + 2);
      continue;
    }
    block.gamma(1);  // a new table follows
    table_index[g] = tables++;
    const size_t base = size_t{g} * alphabet;
    const auto [model, code] = choose_model(&counts[base], alphabet);
    write_model(&block, model, code);
    const std::vector<uint32_t> f = normalize(model.weights);
    uint32_t cumulative = 0;
    for (size_t i = 0; i < f.size(); ++i) {
      t.freq[base + model.symbols[i]] = static_cast<uint16_t>(f[i]);
      t.start[base + model.symbols[i]] = static_cast<uint16_t>(cumulative);
      cumulative += f[i];
    }
  }
  t.block = block.bytes();
}

/// Messages for one section: "bone.osteon: connectivity: what (byte N)".
/// Given the pattern and numbers rather than the text (invalid_data): the section decoders have
/// some 30 error returns, each of which would otherwise build its strings itself (a few hundred
/// bytes of the WebAssembly decoder's download).
struct SectionErrors {
  const std::string& source;
  const std::string& what;
  Status operator()(size_t offset, const char* pattern,
                    std::initializer_list<uint64_t> numbers = {}) const {
    return invalid_data(source, offset, what.c_str(), ": ", numbers, pattern);
  }
};

/// The table block as read: the tables, and the table of each context that occurs.
struct TableBlock {
  std::vector<WeightTable> models;
  std::vector<std::pair<uint32_t, uint32_t>> table_of;  // (context, index in models)
};

/// Reads one table (write_model's layout), checking every symbol and weight. Errors name the
/// byte `base` + the reader's position.
OSTEON_COLD_FUNCTION Status read_model(BitReader& bits, uint32_t alphabet, uint64_t context,
                                       const SectionErrors& errors, size_t base,
                                       WeightTable* model) {
  auto bad = [&](const char* pattern, std::initializer_list<uint64_t> numbers = {}) {
    return errors(base + bits.byte_offset(), pattern, numbers);
  };
  uint64_t sparse = 0;
  uint64_t count = 0;  // dense: symbols up to the last present one; sparse: present symbols
  if (!bits.get(1, &sparse) || !bits.gamma(&count)) return bad("truncated frequency tables");
  if (count > alphabet) {
    return bad("% symbols in context %, alphabet %", {count, context, alphabet});
  }
  if (sparse == 1) {
    uint64_t symbol = ~uint64_t{0};  // "-1": the first gap is symbol + 1
    for (uint64_t i = 0; i < count; ++i) {
      uint64_t gap = 0;
      if (!bits.gamma(&gap)) return bad("truncated frequency tables");
      symbol += gap;
      if (symbol >= alphabet) {
        return bad("symbol % out of range in context % (alphabet %)", {symbol, context, alphabet});
      }
      model->symbols.push_back(static_cast<uint32_t>(symbol));
    }
    if (count == 1) {  // deterministic: no weight
      model->weights.push_back(1);
      return Status::ok_status();
    }
  }
  uint64_t order = 0;  // stored + 1
  if (!bits.gamma(&order)) return bad("truncated frequency tables");
  if (order - 1 > kMaxGolombOrder) {
    return bad("bad weight code % in context %", {order - 1, context});
  }
  for (uint64_t i = 0; i < count; ++i) {
    uint64_t weight = 0;
    if (!bits.exp_golomb(static_cast<int>(order - 1), &weight)) {
      return bad("truncated frequency tables");
    }
    weight += sparse;  // sparse weights are stored - 1; dense ones are 0 for absent symbols
    if (weight > 0xffffffffu) return bad("weight out of range in context %", {context});
    if (sparse == 0 && weight != 0) model->symbols.push_back(static_cast<uint32_t>(i));
    if (weight != 0) model->weights.push_back(static_cast<uint32_t>(weight));
  }
  if (model->symbols.empty()) return bad("no symbols in context %", {context});
  return Status::ok_status();
}

/// Reads the table block (FORMAT.md) from `in`, checking every context, reference, symbol and
/// weight.
OSTEON_COLD_FUNCTION Status read_tables(ByteReader& in, uint32_t alphabet, uint32_t contexts,
                                        const SectionErrors& bad, TableBlock* tables) {
  const size_t base = in.offset();
  BitReader bits(in.current(), in.remaining());
  auto bad_here = [&](const char* pattern, std::initializer_list<uint64_t> numbers = {}) {
    return bad(base + bits.byte_offset(), pattern, numbers);
  };
  uint64_t used = 0;
  if (!bits.gamma(&used)) return bad_here("truncated frequency tables");
  if (used > contexts) {
    return bad(base, "% contexts declared, the coder has %", {used, contexts});
  }
  uint64_t context = ~uint64_t{0};  // "-1": the first gap is context + 1
  for (uint64_t u = 0; u < used; ++u) {
    uint64_t gap = 0;
    uint64_t reference = 0;  // 1: a new table follows; r >= 2: the table defined (r - 2)th
    if (!bits.gamma(&gap) || !bits.gamma(&reference)) {
      return bad_here("truncated frequency tables");
    }
    context += gap;
    if (context >= contexts) {
      return bad_here("context % out of range (% contexts)", {context, contexts});
    }
    if (reference == 1) {
      WeightTable model;
      OSTEON_RETURN_IF_ERROR(read_model(bits, alphabet, context, bad, base, &model));
      tables->models.push_back(std::move(model));
      reference = tables->models.size() + 1;
    } else if (reference - 2 >= tables->models.size()) {
      return bad_here("table % named in context %, only % defined",
                      {reference - 2, context, tables->models.size()});
    }
    tables->table_of.emplace_back(static_cast<uint32_t>(context),
                                  static_cast<uint32_t>(reference - 2));
  }
  if (!bits.padding_is_zero()) return bad_here("nonzero padding after the frequency tables");
  (void)in.skip(bits.bytes_used());
  return Status::ok_status();
}

}  // namespace

OSTEON_NOINLINE OSTEON_COLD_FUNCTION Status invalid_data(const std::string& source, size_t at,
                                                         const char* prefix, const char* first,
                                                         std::initializer_list<uint64_t> numbers,
                                                         const char* second) {
  std::string pattern = first;  // appends, not operator+ (fewer functions in the decoder)
  pattern += second;
  std::string text = prefix;
  text += message(pattern.c_str(), numbers);
  return error(ErrorCode::kInvalidData, source, text, at_byte(at));
}

OSTEON_COLD_FUNCTION std::string message(const char* pattern,
                                         std::initializer_list<uint64_t> numbers) {
  std::string out;
  const uint64_t* next = numbers.begin();
  for (const char* p = pattern; *p != 0;) {
    // The text up to the next substituted '%', appended at once.
    const char* end = p;
    while (*end != 0 && (*end != '%' || next == numbers.end())) ++end;
    out.append(p, static_cast<size_t>(end - p));
    if (*end == 0) break;
    append_decimal(*next++, &out);
    p = end + 1;
  }
  return out;
}

// ---- encoder ---------------------------------------------------------------------------------

SymbolEncoder::SymbolEncoder(uint32_t alphabet, uint32_t contexts)
    : alphabet_(alphabet), contexts_(contexts) {
  assert(alphabet >= 2 && alphabet <= kProbScale);
  assert(contexts >= 1 && contexts <= 4096);
}

static_assert(SymbolEncoder::kContextShift == kProbBits,
              "queued symbols are context << 12 | symbol");

SymbolPlan plan_symbols(const std::vector<uint32_t>& counts, const std::vector<uint32_t>& order,
                        uint32_t contexts, uint32_t alphabet) {
  assert(counts.size() == size_t{contexts} * alphabet);
  SymbolPlan p;
  if (order.empty()) return p;
  p.row.assign(contexts, kUnusedRow);
  const uint32_t used = static_cast<uint32_t>(order.size());
  std::vector<uint32_t> used_counts(size_t{used} * alphabet);
  for (uint32_t r = 0; r < used; ++r) {
    p.row[order[r]] = r;
    std::copy_n(&counts[size_t{order[r]} * alphabet], alphabet, &used_counts[size_t{r} * alphabet]);
  }
  plan_tables(used, alphabet, &used_counts, &p);
  // Each group row now holds its members' counts, all coded with its table.
  p.bits = 8.0 * p.block.size();
  for (uint32_t r = 0; r < used; ++r) {
    if (p.group[r] != r) continue;
    for (uint32_t s = 0; s < alphabet; ++s) {
      const size_t i = size_t{r} * alphabet + s;
      if (used_counts[i] > 0) p.bits += used_counts[i] * (kProbBits - std::log2(p.freq[i]));
    }
  }
  return p;
}

SymbolPlan SymbolEncoder::plan() const {
  SymbolPlan p;
  // Count the symbols of each context that occurs; p.row[c] indexes its counts.
  p.row.assign(contexts_, kUnusedRow);
  uint32_t used = 0;
  for (uint32_t q : queued_) {
    if (p.row[q >> kProbBits] == kUnusedRow) p.row[q >> kProbBits] = used++;
  }
  std::vector<uint32_t> counts(size_t{used} * alphabet_, 0);
  for (uint32_t q : queued_)
    ++counts[size_t{p.row[q >> kProbBits]} * alphabet_ + (q & (kProbScale - 1))];
  plan_tables(used, alphabet_, &counts, &p);
  return p;
}

void SymbolEncoder::use_plan(SymbolPlan plan) {
  plan_ = std::move(plan);
}

uint32_t SymbolEncoder::append_to(std::vector<uint8_t>* out, uint32_t end_state,
                                  bool chained) const {
  assert(end_state >= kRansLow && end_state < (1u << 31));
  const size_t n = queued_.size();
  ByteWriter(out).write_varint(bit_count_);
  uint32_t first_state = end_state;  // an empty section hands the chain on
  if (n > 0) {
    SymbolPlan planned;
    const SymbolPlan& tables = plan_.has_value() ? *plan_ : (planned = plan());
    const std::vector<uint32_t>& row = tables.row;
    const std::vector<uint32_t>& group = tables.group;
    const std::vector<uint16_t>& freq = tables.freq;
    const std::vector<uint16_t>& start = tables.start;
    out->insert(out->end(), tables.block.begin(), tables.block.end());

    // rANS, last symbol first, bytes written backwards into one buffer that all states share:
    // each symbol emits at most two. The decoder reads them forwards, each step's bytes where
    // the encoder's same step wrote them.
    const uint32_t state_count = states_for(n);
    std::vector<uint8_t> buffer(2 * n + 4 * kStates);
    uint8_t* const end = buffer.data() + buffer.size();
    uint8_t* p = end;
    uint32_t states[kStates];
    std::fill(states, states + kStates, kRansLow);
    // The state the decoder holds as x0 once every symbol is decoded (its states rotate once a
    // symbol) carries the chain on: state n mod S.
    states[n % state_count] = end_state;
    for (size_t i = n; i-- > 0;) {
      const uint32_t q = queued_[i];
      const size_t index = size_t{group[row[q >> kProbBits]]} * alphabet_ + (q & (kProbScale - 1));
      const uint32_t f = freq[index];
      const uint32_t x_max = ((kRansLow >> kProbBits) << 8) * f;  // <= 2^31
      uint32_t& x = states[i % state_count];
      while (x >= x_max) {
        *--p = static_cast<uint8_t>(x);
        x >>= 8;
      }
      x = ((x / f) << kProbBits) + (x % f) + start[index];
    }
    // The final states, little-endian, state 0 first: the decoder's initial states (state 0
    // not, where the section before hands it over). The rANS bytes run up to the raw bits, the
    // section's last bytes.
    const uint32_t first = chained ? 1 : 0;
    p -= 4 * (state_count - first);
    for (uint32_t k = first; k < state_count; ++k) {
      for (int i = 0; i < 4; ++i) {
        p[4 * (k - first) + i] = static_cast<uint8_t>(states[k] >> (8 * i));
      }
    }
    out->insert(out->end(), p, end);
    first_state = states[0];
  }
  for (uint32_t word : words_) {  // little-endian: the stream is LSB-first
    for (int i = 0; i < 4; ++i) out->push_back(static_cast<uint8_t>(word >> (8 * i)));
  }
  for (int i = 0; i < (pending_bits_ + 7) / 8; ++i) {
    out->push_back(static_cast<uint8_t>(pending_ >> (8 * i)));
  }
  return first_state;
}

// ---- decoder ---------------------------------------------------------------------------------

OSTEON_NOINLINE OSTEON_COLD_FUNCTION Status SymbolDecoder::init(ByteReader& in, uint32_t alphabet,
                                                                uint32_t contexts,
                                                                SectionLayout layout,
                                                                const std::string& source,
                                                                const std::string& what) {
  assert(alphabet >= 2 && alphabet <= kProbScale);
  assert(contexts >= 1 && contexts <= kMaxContexts);
  *this = SymbolDecoder();
  const SectionErrors bad{source, what};
  const bool compact = layout.version >= kCompactSectionVersion;

  size_t at = in.offset();
  uint64_t symbols = layout.symbols;
  if (!compact && !in.read_varint(&symbols)) return bad(at, "truncated symbol count");
  if (symbols > kMaxSymbols) {
    return bad(at, "% symbols declared, more than 2^32 - 1", {symbols});
  }
  at = in.offset();
  uint64_t bit_count = 0;
  if (!in.read_varint(&bit_count)) return bad(at, "truncated raw bit count");
  const uint64_t bit_bytes = bit_count / 8 + (bit_count % 8 != 0 ? 1 : 0);
  if (!in.fits(bit_bytes, 1)) {
    return bad(at, "% raw bits declared, % bytes remain", {bit_count, in.remaining()});
  }

  // An empty stream "ends" where the encoder started (a chained one hands its first state on).
  const bool chained = compact && layout.first_state != 0;
  assert(!chained || (layout.first_state >= kRansLow && layout.first_state < (1u << 31)));
  more_ = compact && layout.more;
  hot_.x0 = chained ? layout.first_state : kRansLow;
  hot_.x1 = hot_.x2 = kRansLow;
  if (symbols > 0) {
    TableBlock tables;
    OSTEON_RETURN_IF_ERROR(read_tables(in, alphabet, contexts, bad, &tables));
    const std::vector<WeightTable>& models = tables.models;
    at = in.offset();
    // Version 8: the rANS bytes are what the raw bits leave; one state for a short section.
    uint64_t rans_bytes = 0;
    if (compact) {
      rans_bytes = in.remaining() - std::min<uint64_t>(in.remaining(), bit_bytes);
    } else if (!in.read_varint(&rans_bytes)) {
      return bad(at, "truncated rANS byte count");
    }
    const uint32_t states = compact ? states_for(symbols) : kStates;
    const uint32_t first = chained ? 1 : 0;  // state 0 handed over, not written
    if (rans_bytes < 4 * (states - first) || !in.fits(rans_bytes, 1) ||
        in.remaining() - rans_bytes < bit_bytes) {
      return bad(at, "% rANS bytes, % bytes remain for them and % raw bytes",
                 {rans_bytes, in.remaining(), bit_bytes});
    }
    // Unless a context is deterministic (its symbols cost no bits), every symbol costs bits.
    bool deterministic = false;
    for (const WeightTable& m : models) deterministic = deterministic || m.symbols.size() == 1;
    if (!deterministic && symbols > kSymbolsPerByte * (rans_bytes + 4 * first - 3 * states)) {
      return bad(at, "% symbols cannot fit in % rANS bytes", {symbols, rans_bytes});
    }
    rans_at_ = in.offset();
    uint32_t x[kStates] = {hot_.x0, kRansLow, kRansLow};
    for (uint32_t k = first; k < states; ++k) {
      (void)in.read_le(&x[k]);  // rans_bytes >= 4 * states remain
      if (x[k] < kRansLow || x[k] >= (1u << 31)) {
        return bad(in.offset() - 4, "initial rANS state out of range");
      }
    }
    static_assert(kStates == 3);
    hot_.x0 = x[0];
    hot_.x1 = x[1];
    hot_.x2 = x[2];
    single_ = states == 1;
    state_bytes_ = 4 * (states - first);
    data_ = in.current();
    hot_.cur = data_;
    end_ = data_ + (rans_bytes - state_bytes_);
    (void)in.skip(static_cast<size_t>(rans_bytes - state_bytes_));

    // Search tables (entropy.hpp): cumulative frequencies per context for small alphabets,
    // entries per table and buckets per context for large ones.
    small_ = alphabet <= kSmallAlphabet;
    contexts_ = contexts;
    std::vector<std::array<uint16_t, 8>> rows(small_ ? models.size() : 0);
    std::vector<TableRef> refs(models.size());
    size_t entries = 0;
    for (const WeightTable& m : models) entries += m.symbols.size() + 1;
    entries_.resize(small_ ? 0 : entries);
    buckets_.resize(small_ ? 0 : models.size() * kBuckets);
    uint32_t base = 0;
    for (size_t t = 0; t < models.size(); ++t) {
      const std::vector<uint32_t> freq = normalize(models[t].weights);
      const std::vector<uint32_t>& present = models[t].symbols;
      if (small_) {
        std::array<uint32_t, 8> f{};
        for (size_t i = 0; i < freq.size(); ++i) f[present[i]] = freq[i];
        uint32_t cumulative = 0;
        for (uint32_t k = 0; k < 8; ++k) {
          rows[t][k] = static_cast<uint16_t>(cumulative);
          cumulative += f[k];
        }
        continue;
      }
      refs[t] = {static_cast<uint32_t>(t * kBuckets), base};
      uint32_t cumulative = 0;
      uint32_t bucket = 0;  // buckets before it are filled
      for (size_t i = 0; i < freq.size(); ++i) {
        entries_[base + i] = cumulative | present[i] << 16;
        cumulative += freq[i];
        // Buckets whose first slot falls in [start, start + freq) belong to entry i.
        for (; bucket < kBuckets && (bucket << (kProbBits - kBucketBits)) < cumulative; ++bucket) {
          buckets_[t * kBuckets + bucket] = static_cast<uint16_t>(i);  // i < alphabet <= 4096
        }
      }
      entries_[base + freq.size()] = kProbScale;  // the sentinel
      base += static_cast<uint32_t>(freq.size() + 1);
    }
    if (small_) {
      cum_.assign(8 * size_t{contexts}, 0);
      for (uint32_t c = 0; c < contexts; ++c) cum_[8 * size_t{c}] = kAbsent;
      for (const auto& [context, t] : tables.table_of) {
        std::copy(rows[t].begin(), rows[t].end(), cum_.begin() + 8 * size_t{context});
      }
    } else {
      table_of_.assign(contexts, TableRef{kNoTable, 0});
      for (const auto& [context, t] : tables.table_of) table_of_[context] = refs[t];
    }
  }

  bits_at_ = in.offset();  // version 8: the raw bits end the section (rans_bytes above)
  bits_ = in.current();
  bit_size_ = bit_count;
  bit_bytes_ = bit_bytes;
  if (bit_count % 8 != 0 && (bits_[bit_bytes - 1] >> (bit_count % 8)) != 0) {
    return bad(bits_at_ + bit_bytes - 1, "nonzero padding after the raw bits");
  }
  (void)in.skip(static_cast<size_t>(bit_bytes));
  hot_.spare = static_cast<size_t>(symbols);
  hot_.ok = true;
  return Status::ok_status();
}

OSTEON_NOINLINE SymbolDecoder::Step SymbolDecoder::get_slow(Cursor c, uint32_t context) const {
  if (c.budget == 0) {  // refill: as many symbols as surely have two bytes each
    c.budget = std::min<size_t>(c.spare, static_cast<size_t>(end_ - c.cur) / 2);
    c.spare -= c.budget;
  }
  const uint32_t x = c.x0;
  const uint32_t slot = x & (kProbScale - 1);
  uint32_t symbol = 0, start = 0, freq = 0;
  if (context >= contexts_ || !find(context, slot, &symbol, &start, &freq)) return failed(c);
  // A symbol of the budget keeps 2 * budget <= end_ - cur (it reads at most two bytes); past the
  // budget, one of the stream's last symbols, whose bytes are checked one by one.
  if (c.budget > 0) {
    --c.budget;
  } else if (c.spare > 0) {
    --c.spare;
  } else {
    return failed(c);
  }
  uint32_t y = freq * (x >> kProbBits) + slot - start;
  while (y < kRansLow) {
    if (c.cur == end_) return failed(c);
    y = (y << 8) | *c.cur++;
  }
  advance(c, y);
  return {c, symbol};
}

// Out of line, so that get3() inlines one copy of the fast path, not four.
void SymbolDecoder::get3_slow(Cursor& c, const uint32_t context[3], uint32_t symbol[3]) const {
  for (int k = 0; k < 3; ++k) symbol[k] = get(c, context[k]);
}

SymbolDecoder::Step SymbolDecoder::get_bits_slow(Cursor c, int count) const {
  if (c.bit_pos + static_cast<uint64_t>(count) > bit_size_) {
    c.bit_pos = bit_size_;
    return failed(c);
  }
  uint64_t value = 0;
  for (int i = 0; i < count; ++i, ++c.bit_pos) {
    value |= static_cast<uint64_t>((bits_[c.bit_pos >> 3] >> (c.bit_pos & 7)) & 1) << i;
  }
  return {c, value};
}

OSTEON_COLD_FUNCTION Status SymbolDecoder::finish(const std::string& source,
                                                  const std::string& what) const {
  const SectionErrors bad{source, what};
  if (!hot_.ok) return bad(rans_at_, "corrupt symbol stream, or one read past its end");
  if (symbols_left() != 0) {
    return bad(rans_at_, "% symbols left unread", {symbols_left()});
  }
  if (hot_.cur != end_) {
    return bad(rans_at_ + state_bytes_ + static_cast<size_t>(hot_.cur - data_),
               "% rANS bytes left unread", {static_cast<uint64_t>(end_ - hot_.cur)});
  }
  // The state left in x0 of a section that another follows is where that one starts.
  if ((!more_ && hot_.x0 != kRansLow) || hot_.x1 != kRansLow || hot_.x2 != kRansLow) {
    return bad(rans_at_, "the rANS states do not end where they began");
  }
  if (hot_.bit_pos != bit_size_) {
    return bad(bits_at_ + static_cast<size_t>(hot_.bit_pos / 8), "% raw bits left unread",
               {bit_size_ - hot_.bit_pos});
  }
  return Status::ok_status();
}

}  // namespace osteon::detail
