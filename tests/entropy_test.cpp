// SPDX-License-Identifier: Apache-2.0
#include "codec/entropy.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "core/byte_io.hpp"

namespace osteon::detail {
namespace {
namespace entropy_test {

// std::mt19937 returning uint32_t (its own result_type is uint_fast32_t, 64 bits on Linux).
struct Rng {
  using result_type = uint32_t;
  explicit Rng(uint32_t seed) : engine(seed) {}
  static constexpr uint32_t min() { return 0; }
  static constexpr uint32_t max() { return 0xffffffffu; }
  uint32_t operator()() { return static_cast<uint32_t>(engine()); }
  std::mt19937 engine;
};

// A script of what the encoder was given, replayed against the decoder.
struct Item {
  bool raw = false;    // put_bits rather than put
  uint32_t a = 0;      // context, or bit count
  uint32_t value = 0;  // symbol, or bits
};
using Script = std::vector<Item>;

struct Coder {
  uint32_t alphabet;
  uint32_t contexts;
};

std::vector<uint8_t> encode(const Script& script, Coder coder) {
  SymbolEncoder enc(coder.alphabet, coder.contexts);
  for (const Item& item : script) {
    if (item.raw) {
      enc.put_bits(item.value, static_cast<int>(item.a));
    } else {
      enc.put(item.a, item.value);
    }
  }
  std::vector<uint8_t> out;
  enc.append_to(&out);
  return out;
}

// The layout the encoder writes (stream version 8), for a section of the script's symbols: the
// enclosing section knows their count.
SectionLayout current(const Script& script) {
  const auto symbols =
      std::count_if(script.begin(), script.end(), [](const Item& i) { return !i.raw; });
  return {kCompactSectionVersion, static_cast<uint64_t>(symbols)};
}
// Versions 1 to 7: the section states its counts (the hand-made sections below).
constexpr SectionLayout kVersion7{7, 0};

uint32_t masked(uint32_t value, uint32_t bits) {
  return bits == 32 ? value : value & ((uint32_t{1} << bits) - 1);
}

// Decodes `bytes` and compares with `script`; the reader must end exactly at the section's end.
::testing::AssertionResult decodes_to(const std::vector<uint8_t>& bytes, const Script& script,
                                      Coder coder, std::optional<SectionLayout> layout = {}) {
  ByteReader in(bytes.data(), bytes.size());
  SymbolDecoder dec;
  Status status = dec.init(in, coder.alphabet, coder.contexts, layout.value_or(current(script)),
                           "test", "symbols");
  if (!status.ok()) return ::testing::AssertionFailure() << "init: " << status.message();
  if (in.remaining() != 0) return ::testing::AssertionFailure() << in.remaining() << " bytes left";
  for (size_t i = 0; i < script.size(); ++i) {
    const Item& item = script[i];
    const uint32_t got = item.raw ? dec.get_bits(static_cast<int>(item.a)) : dec.get(item.a);
    const uint32_t want = item.raw ? masked(item.value, item.a) : item.value;
    if (got != want) {
      return ::testing::AssertionFailure() << "item " << i << (item.raw ? " (bits)" : " (symbol)")
                                           << ": got " << got << ", want " << want;
    }
  }
  if (!dec.ok()) return ::testing::AssertionFailure() << "ok() is false";
  status = dec.finish("test", "symbols");
  if (!status.ok()) return ::testing::AssertionFailure() << "finish: " << status.message();
  return ::testing::AssertionSuccess();
}

/// Symbols with a geometric-like distribution whose skew depends on the context.
Script skewed_script(size_t count, Coder coder, uint32_t seed) {
  Rng rng(seed);
  Script script;
  for (size_t i = 0; i < count; ++i) {
    const uint32_t context = rng() % coder.contexts;
    const double p = 0.3 + 0.65 * (context + 1) / coder.contexts;  // P(stop) per step
    std::geometric_distribution<uint32_t> geometric(p);
    const uint32_t symbol = std::min(geometric(rng), coder.alphabet - 1);
    script.push_back({false, context, symbol});
  }
  return script;
}

double entropy_bits(const std::vector<uint64_t>& counts) {
  uint64_t total = 0;
  for (uint64_t c : counts) total += c;
  double bits = 0;
  for (uint64_t c : counts) {
    if (c > 0) bits -= static_cast<double>(c) * std::log2(static_cast<double>(c) / total);
  }
  return bits;
}

TEST(Entropy, RoundTripsSkewedContexts) {
  for (uint32_t seed = 1; seed <= 5; ++seed) {
    SCOPED_TRACE(seed);
    const Coder coder{16 + seed * 7, 1 + seed * 3};
    const Script script = skewed_script(20000 * seed, coder, seed);
    EXPECT_TRUE(decodes_to(encode(script, coder), script, coder));
  }
}

TEST(Entropy, RoundTripsContextsWithOneSymbol) {
  const Coder coder{8, 4};
  Rng rng(7);
  Script script;
  for (int i = 0; i < 5000; ++i) {
    const uint32_t context = rng() % 4;
    // Contexts 0 and 2 only ever see one symbol (deterministic: 0 bits), 1 and 3 see several.
    const uint32_t symbol = context == 0 ? 5 : context == 2 ? 0 : rng() % 8;
    script.push_back({false, context, symbol});
  }
  EXPECT_TRUE(decodes_to(encode(script, coder), script, coder));
}

TEST(Entropy, OneSymbolStreamCostsOnlyItsTable) {
  const Coder coder{4, 1};
  const Script script(1000000, Item{false, 0, 3});
  const std::vector<uint8_t> bytes = encode(script, coder);
  EXPECT_LE(bytes.size(), 12u + 4);  // its raw bit count, the table and three rANS states
  EXPECT_TRUE(decodes_to(bytes, script, coder));
}

TEST(Entropy, RoundTripsAlphabetTwo) {
  const Coder coder{2, 3};
  Rng rng(11);
  Script script;
  for (int i = 0; i < 30000; ++i) {
    const uint32_t context = rng() % 3;
    script.push_back({false, context, (rng() % 100) < 5 + 40 * context ? 1u : 0u});
  }
  EXPECT_TRUE(decodes_to(encode(script, coder), script, coder));
}

TEST(Entropy, RoundTripsAlphabet4096) {
  const Coder coder{4096, 2};
  Rng rng(13);
  Script script;
  // Context 0: every symbol at least once (4096 frequencies of exactly 1 each); context 1: skewed.
  for (uint32_t s = 0; s < 4096; ++s) script.push_back({false, 0, s});
  for (int i = 0; i < 50000; ++i) {
    script.push_back({false, 0, rng() % 4096});
    script.push_back({false, 1, std::min<uint32_t>(4095, (rng() % 64) * (rng() % 64))});
  }
  std::shuffle(script.begin(), script.end(), rng);
  EXPECT_TRUE(decodes_to(encode(script, coder), script, coder));
}

TEST(Entropy, RoundTripsOneRareSymbolAmongMany) {
  // 4095 occurrences of many distinct symbols next to a huge count: the forced minimum of one
  // slot each leaves little for the common symbol, which normalisation must still handle.
  const Coder coder{4096, 1};
  Script script;
  for (uint32_t s = 1; s < 4096; ++s) script.push_back({false, 0, s});
  for (int i = 0; i < 200000; ++i) script.push_back({false, 0, 0});
  Rng rng(17);
  std::shuffle(script.begin(), script.end(), rng);
  EXPECT_TRUE(decodes_to(encode(script, coder), script, coder));
}

TEST(Entropy, ExtremelySkewedStreamsFitTheSymbolBound) {
  // One rare symbol among millions: about 0.00035 bits per common symbol, the densest a stream
  // of two-symbol contexts gets; init's symbols-per-byte bound must accept it.
  const Coder coder{2, 1};
  Script script(3000000, Item{false, 0, 0});
  script[1234567].value = 1;
  const std::vector<uint8_t> bytes = encode(script, coder);
  std::printf("[          ] 3M symbols, one of them rare: %zu bytes\n", bytes.size());
  EXPECT_TRUE(decodes_to(bytes, script, coder));
}

TEST(Entropy, DecoderCanBeReusedAndFailsSafelyUninitialised) {
  SymbolDecoder dec;
  EXPECT_EQ(dec.get(0), 0u);
  EXPECT_EQ(dec.get_bits(7), 0u);
  EXPECT_FALSE(dec.ok());
  EXPECT_FALSE(dec.finish("test", "symbols").ok());
  for (uint32_t seed = 1; seed <= 3; ++seed) {
    const Coder coder{3 + seed, seed};
    const Script script = skewed_script(500 * seed, coder, seed);
    const std::vector<uint8_t> bytes = encode(script, coder);
    ByteReader in(bytes.data(), bytes.size());
    ASSERT_TRUE(
        dec.init(in, coder.alphabet, coder.contexts, current(script), "test", "symbols").ok());
    for (const Item& item : script) ASSERT_EQ(dec.get(item.a), item.value);
    EXPECT_TRUE(dec.finish("test", "symbols").ok());
  }
}

TEST(Entropy, EmptyStream) {
  const Coder coder{5, 3};
  const std::vector<uint8_t> bytes = encode({}, coder);
  EXPECT_EQ(bytes, (std::vector<uint8_t>{0}));  // no raw bits, and nothing else
  EXPECT_TRUE(decodes_to(bytes, {}, coder));

  ByteReader in(bytes.data(), bytes.size());
  SymbolDecoder dec;
  ASSERT_TRUE(dec.init(in, coder.alphabet, coder.contexts, current({}), "test", "symbols").ok());
  EXPECT_EQ(dec.symbols_left(), 0u);
  EXPECT_EQ(dec.get(0), 0u);
  EXPECT_FALSE(dec.ok());
  EXPECT_FALSE(dec.finish("test", "symbols").ok());
}

TEST(Entropy, RawBitsOnly) {
  const Coder coder{2, 1};
  Script script;
  for (uint32_t w = 0; w <= 32; ++w) script.push_back({true, w, 0xdeadbeefu * (w + 1)});
  EXPECT_TRUE(decodes_to(encode(script, coder), script, coder));
}

TEST(Entropy, InterleavesSymbolsAndRawBitsOfEveryWidth) {
  const Coder coder{12, 5};
  Rng rng(19);
  Script script;
  for (int i = 0; i < 40000; ++i) {
    if (rng() % 3 == 0) {
      script.push_back({true, static_cast<uint32_t>(rng() % 33), static_cast<uint32_t>(rng())});
    } else {
      const uint32_t context = rng() % 5;
      script.push_back({false, context, (rng() % 12) * (rng() % 2) * (context % 2)});
    }
  }
  EXPECT_TRUE(decodes_to(encode(script, coder), script, coder));
}

// The hot loops' interface: a cursor in a local, three symbols at a time (get3) and up to 56 raw
// bits at once, read the same stream as get() and get_bits(), for small alphabets (searched by
// cumulative frequencies) and large ones (buckets), up to the stream's last bytes (the checked
// slow paths), with absent contexts failing cleanly.
TEST(Entropy, CursorGet3AndWideBitsReadWhatGetReads) {
  for (const Coder coder : {Coder{5, 40}, Coder{68, 24}, Coder{4096, 3}}) {
    SCOPED_TRACE(coder.alphabet);
    Rng rng(coder.alphabet);
    Script script;
    std::vector<uint32_t> widths;  // per group of three symbols: their raw bits, 0..56
    for (int i = 0; i < 3000; ++i) {
      for (int k = 0; k < 3; ++k) {
        const uint32_t context = rng() % coder.contexts;
        script.push_back({false, context, (rng() % coder.alphabet) / (1 + context % 4)});
      }
      const uint32_t width = rng() % 57;
      widths.push_back(width);
      const uint64_t bits = (uint64_t{rng()} << 32 | rng()) & ((uint64_t{1} << width) - 1);
      if (width > 32) {  // put_bits takes at most 32 at a time
        script.push_back({true, 32, static_cast<uint32_t>(bits)});
        script.push_back({true, width - 32, static_cast<uint32_t>(bits >> 32)});
      } else {
        script.push_back({true, width, static_cast<uint32_t>(bits)});
      }
    }
    const std::vector<uint8_t> bytes = encode(script, coder);
    ASSERT_TRUE(decodes_to(bytes, script, coder));
    ByteReader in(bytes.data(), bytes.size());
    SymbolDecoder dec;
    ASSERT_TRUE(
        dec.init(in, coder.alphabet, coder.contexts, current(script), "test", "symbols").ok());
    SymbolDecoder::Cursor cursor = dec.cursor();
    size_t item = 0;
    for (uint32_t width : widths) {
      uint32_t context[3], symbol[3];
      for (int k = 0; k < 3; ++k) context[k] = script[item + k].a;
      dec.get3(cursor, context, symbol);
      for (int k = 0; k < 3; ++k) ASSERT_EQ(symbol[k], script[item + k].value) << item + k;
      item += 3;
      uint64_t want = script[item].value;
      if (width > 32) want |= uint64_t{script[++item].value} << 32;
      ++item;
      ASSERT_EQ(dec.get_bits(cursor, static_cast<int>(width)), want) << item;
    }
    ASSERT_TRUE(cursor.ok);
    dec.resume(cursor);
    EXPECT_TRUE(dec.finish("test", "symbols").ok());
    // One more symbol, past the end: fails cleanly, through get3 too.
    cursor = dec.cursor();
    uint32_t context[3] = {0, 0, 0}, symbol[3];
    dec.get3(cursor, context, symbol);
    EXPECT_FALSE(cursor.ok);
  }
}

TEST(Entropy, Get3FailsCleanlyOnAnAbsentContext) {
  const Coder coder{68, 4};
  Script script;
  for (int i = 0; i < 30; ++i) script.push_back({false, static_cast<uint32_t>(i % 2), 7});
  const std::vector<uint8_t> bytes = encode(script, coder);
  ByteReader in(bytes.data(), bytes.size());
  SymbolDecoder dec;
  ASSERT_TRUE(
      dec.init(in, coder.alphabet, coder.contexts, current(script), "test", "symbols").ok());
  SymbolDecoder::Cursor cursor = dec.cursor();
  const uint32_t context[3] = {0, 3, 1};  // context 3 never occurs
  uint32_t symbol[3];
  dec.get3(cursor, context, symbol);
  EXPECT_FALSE(cursor.ok);
}

TEST(Entropy, CompressesWithinOnePercentOfTheEntropy) {
  const Coder coder{2, 1};
  Rng rng(23);
  std::bernoulli_distribution rare(0.1);
  Script script;
  std::vector<uint64_t> counts(2, 0);
  for (int i = 0; i < 100000; ++i) {
    const uint32_t s = rare(rng) ? 1 : 0;
    ++counts[s];
    script.push_back({false, 0, s});
  }
  const std::vector<uint8_t> bytes = encode(script, coder);
  const double entropy = entropy_bits(counts);
  const double overhead = 8 * 24;  // varints, table, the three rANS states
  std::printf("[          ] p = 0.9/0.1, 100k symbols: %zu bytes, entropy %.0f bytes (%+.3f%%)\n",
              bytes.size(), entropy / 8, 100 * (8 * bytes.size() / entropy - 1));
  EXPECT_LE(8.0 * bytes.size(), 1.01 * entropy + overhead);
  EXPECT_TRUE(decodes_to(bytes, script, coder));
}

TEST(Entropy, ManyContextsCompressNearTheirEntropy) {
  // The sum of the per-context entropies bounds what a static model can do; normalisation to 12
  // bits and rounding must stay close to it when there are enough symbols per context.
  const Coder coder{40, 12};
  const Script script = skewed_script(300000, coder, 29);
  std::vector<std::vector<uint64_t>> counts(coder.contexts, std::vector<uint64_t>(40, 0));
  for (const Item& item : script) ++counts[item.a][item.value];
  double entropy = 0;
  for (const auto& c : counts) entropy += entropy_bits(c);
  const std::vector<uint8_t> bytes = encode(script, coder);
  std::printf("[          ] 12 contexts, 300k symbols: %zu bytes, entropy %.0f bytes (%+.3f%%)\n",
              bytes.size(), entropy / 8, 100 * (8 * bytes.size() / entropy - 1));
  EXPECT_LE(8.0 * bytes.size(), 1.01 * entropy + 8 * 200);
  EXPECT_TRUE(decodes_to(bytes, script, coder));
}

TEST(Entropy, SmallStreamTablesAreSmall) {
  // About what a 300-triangle mesh's connectivity gives: ~300 symbols over 5 contexts.
  const Coder coder{5, 5};
  Rng rng(31);
  Script script;
  uint32_t previous = 0;
  for (int i = 0; i < 300; ++i) {
    const uint32_t s = rng() % 2 == 0 ? 0 : rng() % 5;
    script.push_back({false, previous, s});
    previous = s;
  }
  std::vector<std::vector<uint64_t>> counts(5, std::vector<uint64_t>(5, 0));
  for (const Item& item : script) ++counts[item.a][item.value];
  double entropy = 0;
  for (const auto& c : counts) entropy += entropy_bits(c);
  const std::vector<uint8_t> bytes = encode(script, coder);
  std::printf("[          ] 300 symbols, 5 contexts: %zu bytes, entropy %.1f bytes\n", bytes.size(),
              entropy / 8);
  EXPECT_LE(bytes.size(), entropy / 8 + 40);
  EXPECT_TRUE(decodes_to(bytes, script, coder));
}

TEST(Entropy, ManySparseContextsShareTables) {
  // 200 contexts seeing 10 symbols each, drawn from three distributions: the encoder should code
  // them with a few shared tables, close to the entropy of the three pooled distributions.
  const Coder coder{35, 200};
  Rng rng(59);
  Script script;
  std::vector<std::vector<uint64_t>> pooled(3, std::vector<uint64_t>(35, 0));
  for (int i = 0; i < 2000; ++i) {
    const uint32_t context = static_cast<uint32_t>(i % 200);
    const uint32_t family = context % 3;
    std::geometric_distribution<uint32_t> geometric(0.2 + 0.3 * family);
    const uint32_t symbol = std::min<uint32_t>(geometric(rng) + 4 * family, 34);
    ++pooled[family][symbol];
    script.push_back({false, context, symbol});
  }
  double entropy = 0;
  for (const auto& c : pooled) entropy += entropy_bits(c);
  const std::vector<uint8_t> bytes = encode(script, coder);
  std::printf("[          ] 200 contexts, 2000 symbols: %zu bytes, pooled entropy %.0f bytes\n",
              bytes.size(), entropy / 8);
  // Naming a table costs each context about 6 bits; without sharing the section is ~920 bytes.
  EXPECT_LE(bytes.size(), entropy / 8 + 200 * 6 / 8 + 60);
  EXPECT_TRUE(decodes_to(bytes, script, coder));
}

// A version-8 stream's sections form one chain of rANS states: each later section's state 0
// starts where the one before left it (not written), and only the last ends at 2^23. Three
// sections of 5,002 (three states, rotated twice at the end), 4,097 (rotated once) and 300
// symbols (one state) decode in turn; a chain entered at the wrong state fails.
TEST(Entropy, SectionsChainTheirStates) {
  const Coder coder{10, 3};
  const Script scripts[3] = {skewed_script(5002, coder, 61), skewed_script(4097, coder, 62),
                             skewed_script(300, coder, 63)};
  std::vector<uint8_t> sections[3];
  uint32_t next = kRansLow;
  for (int k = 2; k >= 0; --k) {
    SymbolEncoder enc(coder.alphabet, coder.contexts);
    for (const Item& item : scripts[k]) enc.put(item.a, item.value);
    next = enc.append_to(&sections[k], next, /*chained=*/k > 0);
  }
  // Unchained, the same symbols take 4 bytes more per later section (their state 0), give or take
  // the byte that a different state 0 may renormalise.
  for (int k = 1; k < 3; ++k) {
    EXPECT_NEAR(double(encode(scripts[k], coder).size()), double(sections[k].size() + 4), 1) << k;
  }
  for (uint32_t wrong : {0u, 1u}) {
    uint32_t chain = 0;
    Status status;
    for (int k = 0; k < 3 && status.ok(); ++k) {
      SCOPED_TRACE(k);
      ByteReader in(sections[k].data(), sections[k].size());
      SymbolDecoder dec;
      const uint32_t first = k == 0 ? 0 : chain + (k == 2 ? wrong : 0);
      status = dec.init(in, coder.alphabet, coder.contexts,
                        {kCompactSectionVersion, scripts[k].size(), first, k < 2}, "t", "s");
      ASSERT_TRUE(status.ok()) << status.message();
      bool same = true;
      for (const Item& item : scripts[k]) same = same && dec.get(item.a) == item.value;
      status = dec.finish("t", "s");
      if (wrong == 0) {
        EXPECT_TRUE(same);
        EXPECT_TRUE(status.ok()) << status.message();
      }
      chain = dec.last_state();
      EXPECT_GE(chain, kRansLow);
    }
    if (wrong != 0) {
      EXPECT_FALSE(status.ok()) << "a chain entered one state off";
    }
  }
}

// A version-8 section runs to its reader's end (the enclosing section's length bounds it): two
// sections side by side decode through readers of their own, and a byte after a section's raw
// bits is an error, not ignored.
TEST(Entropy, SectionsEndWhereTheirReadersEnd) {
  const Coder a{6, 2};
  const Coder b{300, 1};
  const Script first = skewed_script(5000, a, 37);  // three rANS states
  const Script second = skewed_script(777, b, 41);  // one
  std::vector<uint8_t> bytes = encode(first, a);
  const size_t split = bytes.size();
  const std::vector<uint8_t> tail = encode(second, b);
  bytes.insert(bytes.end(), tail.begin(), tail.end());

  ByteReader in1(bytes.data(), split);
  ByteReader in2(bytes.data() + split, bytes.size() - split);
  SymbolDecoder d1;
  SymbolDecoder d2;
  ASSERT_TRUE(d1.init(in1, a.alphabet, a.contexts, current(first), "test", "first").ok());
  ASSERT_TRUE(d2.init(in2, b.alphabet, b.contexts, current(second), "test", "second").ok());
  EXPECT_EQ(in1.remaining(), 0u);
  EXPECT_EQ(in2.remaining(), 0u);
  for (const Item& item : first) EXPECT_EQ(d1.get(item.a), item.value);
  for (const Item& item : second) EXPECT_EQ(d2.get(item.a), item.value);
  EXPECT_TRUE(d1.finish("test", "first").ok());
  EXPECT_TRUE(d2.finish("test", "second").ok());

  // A byte too many, after the raw bits: the raw bits are the section's last bytes, so the
  // decoder reads the wrong ones, and finish() (if decoding got that far) refuses the section.
  Script with_bits = second;
  with_bits.push_back({true, 11, 1234});
  std::vector<uint8_t> longer = encode(with_bits, b);
  longer.push_back(0);
  ByteReader in3(longer.data(), longer.size());
  Status status = d2.init(in3, b.alphabet, b.contexts, current(with_bits), "x.ostm", "y");
  if (status.ok()) {
    for (const Item& item : with_bits) {
      (void)(item.raw ? d2.get_bits(static_cast<int>(item.a)) : d2.get(item.a));
    }
    status = d2.finish("x.ostm", "y");
  }
  EXPECT_FALSE(status.ok());
  EXPECT_EQ(status.message().rfind("x.ostm: y: ", 0), 0u) << status.message();
}

// From version 8 a section of fewer than 4,096 symbols has one rANS state, 4 bytes instead of
// 12: measured on a context of one symbol, whose symbols cost no bits (and no rANS bytes).
TEST(Entropy, ShortSectionsHaveOneRansState) {
  const Coder coder{4, 1};
  const Script short_one(4095, Item{false, 0, 3});
  const Script long_one(4096, Item{false, 0, 3});
  const std::vector<uint8_t> few = encode(short_one, coder);
  const std::vector<uint8_t> many = encode(long_one, coder);
  EXPECT_EQ(many.size(), few.size() + 8);
  EXPECT_TRUE(decodes_to(few, short_one, coder));
  EXPECT_TRUE(decodes_to(many, long_one, coder));
  // And with symbols that cost bits, on both sides of the threshold, through the cursor's get3.
  for (size_t count : {3u, 300u, 4095u, 4096u, 4098u}) {
    SCOPED_TRACE(count);
    const Coder big{68, 5};
    const Script script = skewed_script(count, big, static_cast<uint32_t>(count));
    const std::vector<uint8_t> bytes = encode(script, big);
    ASSERT_TRUE(decodes_to(bytes, script, big));
    ByteReader in(bytes.data(), bytes.size());
    SymbolDecoder dec;
    ASSERT_TRUE(dec.init(in, big.alphabet, big.contexts, current(script), "test", "s").ok());
    SymbolDecoder::Cursor cursor = dec.cursor();
    size_t i = 0;
    for (; i + 3 <= count; i += 3) {
      const uint32_t context[3] = {script[i].a, script[i + 1].a, script[i + 2].a};
      uint32_t symbol[3];
      dec.get3(cursor, context, symbol);
      for (int k = 0; k < 3; ++k) ASSERT_EQ(symbol[k], script[i + k].value) << i + k;
    }
    for (; i < count; ++i) ASSERT_EQ(dec.get(cursor, script[i].a), script[i].value) << i;
    dec.resume(cursor);
    EXPECT_TRUE(dec.finish("test", "s").ok());
  }
}

TEST(Entropy, ReadingPastTheEndFails) {
  const Coder coder{4, 2};
  const Script script = {{false, 0, 1}, {false, 0, 2}, {true, 5, 17}, {false, 1, 3}};
  const std::vector<uint8_t> bytes = encode(script, coder);
  {
    ByteReader in(bytes.data(), bytes.size());
    SymbolDecoder dec;
    ASSERT_TRUE(
        dec.init(in, coder.alphabet, coder.contexts, current(script), "test", "symbols").ok());
    EXPECT_EQ(dec.get(0), 1u);
    EXPECT_EQ(dec.get(0), 2u);
    EXPECT_EQ(dec.get_bits(5), 17u);
    EXPECT_EQ(dec.get(1), 3u);
    EXPECT_TRUE(dec.ok());
    EXPECT_EQ(dec.get(1), 0u);
    EXPECT_FALSE(dec.ok());
  }
  {
    ByteReader in(bytes.data(), bytes.size());
    SymbolDecoder dec;
    ASSERT_TRUE(
        dec.init(in, coder.alphabet, coder.contexts, current(script), "test", "symbols").ok());
    EXPECT_EQ(dec.get_bits(6), 0u);  // only 5 raw bits
    EXPECT_FALSE(dec.ok());
  }
}

TEST(Entropy, AbsentContextFails) {
  const Coder coder{4, 3};
  const Script script = {{false, 0, 1}, {false, 2, 2}};
  const std::vector<uint8_t> bytes = encode(script, coder);
  ByteReader in(bytes.data(), bytes.size());
  SymbolDecoder dec;
  ASSERT_TRUE(
      dec.init(in, coder.alphabet, coder.contexts, current(script), "test", "symbols").ok());
  EXPECT_EQ(dec.get(1), 0u);
  EXPECT_FALSE(dec.ok());
}

TEST(Entropy, FinishReportsWhatWasNotRead) {
  const Coder coder{4, 1};
  const Script script = {{false, 0, 1}, {false, 0, 2}, {false, 0, 1}, {true, 9, 300}};
  const std::vector<uint8_t> bytes = encode(script, coder);
  ByteReader in(bytes.data(), bytes.size());
  SymbolDecoder dec;
  ASSERT_TRUE(
      dec.init(in, coder.alphabet, coder.contexts, current(script), "bone.osteon", "geometry")
          .ok());
  EXPECT_EQ(dec.get(0), 1u);
  Status status = dec.finish("bone.osteon", "geometry");
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("bone.osteon: geometry: 2 symbols left unread"),
            std::string::npos)
      << status.message();
  EXPECT_EQ(dec.get(0), 2u);
  EXPECT_EQ(dec.get(0), 1u);
  status = dec.finish("bone.osteon", "geometry");
  EXPECT_NE(status.message().find("9 raw bits left unread"), std::string::npos) << status.message();
  EXPECT_EQ(dec.get_bits(9), 300u);
  EXPECT_TRUE(dec.finish("bone.osteon", "geometry").ok());
}

/// Decodes `bytes` as far as `script` goes; true when the damage was noticed (init, ok() or
/// finish()). Never more calls than the script has, so a corrupt stream cannot loop.
bool damage_detected(const std::vector<uint8_t>& bytes, const Script& script, Coder coder,
                     bool* wrong_but_unnoticed, std::optional<SectionLayout> layout = {}) {
  ByteReader in(bytes.data(), bytes.size());
  SymbolDecoder dec;
  const SectionLayout l = layout.value_or(current(script));
  if (!dec.init(in, coder.alphabet, coder.contexts, l, "test", "symbols").ok()) return true;
  bool same = true;
  for (const Item& item : script) {
    const uint32_t got = item.raw ? dec.get_bits(static_cast<int>(item.a)) : dec.get(item.a);
    EXPECT_LT(got, item.raw ? uint64_t{1} << item.a : coder.alphabet);
    same = same && got == (item.raw ? masked(item.value, item.a) : item.value);
  }
  if (!dec.ok() || !dec.finish("test", "symbols").ok()) return true;
  *wrong_but_unnoticed = *wrong_but_unnoticed || !same;
  return false;
}

// A version-8 section does not state its rANS bytes' count (they are what the raw bits leave), so
// a cut one may pass init: then decoding or finish() refuses it, naming the section.
TEST(Entropy, EveryTruncationIsRejected) {
  const Coder coder{10, 4};
  for (size_t count : {300u, 5000u}) {  // one rANS state, three
    Script script = skewed_script(count, coder, 43);
    for (uint32_t i = 0; i < 40; ++i) script.insert(script.begin() + 7 * i, {true, i % 33, i * 77});
    const std::vector<uint8_t> bytes = encode(script, coder);
    ASSERT_TRUE(decodes_to(bytes, script, coder));
    for (size_t size = 0; size < bytes.size(); ++size) {
      SCOPED_TRACE(size);
      // A copy of exactly `size` bytes, so ASan sees any read past it.
      const std::vector<uint8_t> prefix(bytes.begin(), bytes.begin() + size);
      ByteReader in(prefix.data(), prefix.size());
      SymbolDecoder dec;
      Status status =
          dec.init(in, coder.alphabet, coder.contexts, current(script), "cut.osteon", "symbols");
      if (status.ok()) {
        for (const Item& item : script) {
          (void)(item.raw ? dec.get_bits(static_cast<int>(item.a)) : dec.get(item.a));
        }
        status = dec.finish("cut.osteon", "symbols");
      }
      ASSERT_FALSE(status.ok());
      EXPECT_EQ(status.code(), ErrorCode::kInvalidData);
      EXPECT_EQ(status.message().rfind("cut.osteon: symbols: ", 0), 0u) << status.message();
      EXPECT_NE(status.message().find("(byte "), std::string::npos) << status.message();
    }
  }
}

TEST(Entropy, BitFlipsAnywhereAreHandled) {
  const Coder coder{10, 4};
  Script script = skewed_script(400, coder, 47);
  for (uint32_t i = 0; i < 20; ++i) script.insert(script.begin() + 11 * i, {true, 3 + i, i * 5});
  const std::vector<uint8_t> bytes = encode(script, coder);
  size_t detected = 0;
  size_t flips = 0;
  bool wrong_but_unnoticed = false;
  for (size_t bit = 0; bit < 8 * bytes.size(); ++bit) {
    std::vector<uint8_t> damaged = bytes;
    damaged[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
    detected += damage_detected(damaged, script, coder, &wrong_but_unnoticed) ? 1 : 0;
    ++flips;
  }
  // Flips in the raw bits cannot be detected (they carry no redundancy); the rest nearly always.
  std::printf("[          ] %zu of %zu single-bit flips detected\n", detected, flips);
  EXPECT_GT(detected, flips / 2);
}

TEST(Entropy, RandomBytesNeverCrash) {
  Rng rng(53);
  const Coder coder{6, 3};
  Script script;
  for (int i = 0; i < 200; ++i) {
    script.push_back({false, static_cast<uint32_t>(i % 3), 0});
    if (i % 9 == 0) script.push_back({true, 13, 0});
  }
  bool unused = false;
  for (int trial = 0; trial < 20000; ++trial) {
    std::vector<uint8_t> bytes(rng() % 64);
    for (uint8_t& b : bytes) b = static_cast<uint8_t>(rng());
    if (trial % 2 == 0 && bytes.size() >= 2) {
      bytes[0] = static_cast<uint8_t>(rng() % 128);  // a plausible symbol count
      bytes[1] = static_cast<uint8_t>(rng() % 128);  // and raw bit count
    }
    (void)damage_detected(bytes, script, coder, &unused);
    (void)damage_detected(bytes, script, coder, &unused, kVersion7);
  }
}

// Writes hand-made tables (the layout of docs/FORMAT.md) for the hostile-count tests.
class TableBits {
 public:
  void put(uint64_t value, int count) {
    for (int i = 0; i < count; ++i, ++n_) {
      if (n_ % 8 == 0) bytes.push_back(0);
      bytes.back() |= static_cast<uint8_t>(((value >> i) & 1) << (n_ % 8));
    }
  }
  void gamma(uint64_t value) {
    int width = 0;
    while ((value >> width) > 1) ++width;
    put(0, width);
    put(1, 1);
    put(value, width);
  }
  std::vector<uint8_t> bytes;

 private:
  int n_ = 0;
};

std::vector<uint8_t> varint(uint64_t value) {
  std::vector<uint8_t> out;
  while (value >= 0x80) {
    out.push_back(static_cast<uint8_t>(value | 0x80));
    value >>= 7;
  }
  out.push_back(static_cast<uint8_t>(value));
  return out;
}

std::vector<uint8_t> concat(std::initializer_list<std::vector<uint8_t>> parts) {
  std::vector<uint8_t> out;
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

Status init_on(const std::vector<uint8_t>& bytes, SymbolDecoder* dec) {
  ByteReader in(bytes.data(), bytes.size());
  return dec->init(in, 4, 2, kVersion7, "evil.osteon", "symbols");
}

TEST(Entropy, HugeDeclaredCountsFailFast) {
  SymbolDecoder dec;
  // More symbols than 2^32 - 1, with nothing behind them.
  Status status = init_on(concat({varint(uint64_t{1} << 40), varint(0)}), &dec);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("more than 2^32 - 1"), std::string::npos) << status.message();
  // A huge raw bit count.
  status = init_on(concat({varint(0), varint(uint64_t{1} << 60)}), &dec);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("raw bits declared"), std::string::npos) << status.message();

  // 4e9 symbols in 12 rANS bytes (the three states), every context with two symbols (each
  // symbol costs bits).
  const uint64_t n = 4000000000u;
  const std::vector<uint8_t> state = {0, 0, 0x80, 0, 0, 0, 0x80, 0, 0, 0, 0x80, 0};  // 3 x 2^23
  TableBits t;
  t.gamma(1);   // one context
  t.gamma(1);   // context 0
  t.gamma(1);   // a new table
  t.put(1, 1);  // sparse
  t.gamma(2);   // two symbols
  t.gamma(1);   // symbol 0
  t.gamma(1);   // symbol 1
  t.gamma(1);   // Golomb order 0
  t.gamma(1);   // weight 1 (stored - 1, order 0: gamma(weight))
  t.gamma(1);   // weight 1
  status = init_on(concat({varint(n), varint(0), t.bytes, varint(12), state}), &dec);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("cannot fit in 12 rANS bytes"), std::string::npos)
      << status.message();

  // The same count in a one-symbol context is legitimate (such symbols cost nothing): the caller
  // bounds it by the count its own header promises.
  TableBits one;
  one.gamma(1);
  one.gamma(1);
  one.gamma(1);
  one.put(1, 1);
  one.gamma(1);  // one symbol
  one.gamma(3);  // symbol 2 (no weight for a lone symbol)
  ASSERT_TRUE(init_on(concat({varint(n), varint(0), one.bytes, varint(12), state}), &dec).ok());
  EXPECT_EQ(dec.symbols_left(), n);
  EXPECT_EQ(dec.get(0), 2u);
  EXPECT_EQ(dec.get(1), 0u);  // context 1 is absent
  EXPECT_FALSE(dec.ok());
}

TEST(Entropy, InconsistentTablesAreRejected) {
  SymbolDecoder dec;
  const std::vector<uint8_t> state = {0, 0, 0x80, 0, 0, 0, 0x80, 0, 0, 0, 0x80, 0};
  // One context holding one symbol (sparse), then `extra` bits.
  auto lone = [](uint64_t context_gap, uint64_t symbol_gap, int extra = 0) {
    TableBits t;
    t.gamma(1);
    t.gamma(context_gap);
    t.gamma(1);  // a new table
    t.put(1, 1);
    t.gamma(1);
    t.gamma(symbol_gap);
    t.put(1, extra);
    return t.bytes;
  };
  // One dense context: symbols 0..weights.size()-1 with these weights (order 0).
  auto dense = [](std::vector<uint64_t> weights, uint64_t order_plus_one = 1) {
    TableBits t;
    t.gamma(1);
    t.gamma(1);
    t.gamma(1);  // a new table
    t.put(0, 1);
    t.gamma(weights.size());
    t.gamma(order_plus_one);
    for (uint64_t w : weights) t.gamma(w + 1);
    return t.bytes;
  };
  auto rejected_with = [&](const std::vector<uint8_t>& bytes, const std::string& what) {
    const Status status = init_on(bytes, &dec);
    if (status.ok()) return ::testing::AssertionFailure() << "accepted";
    if (status.message().find(what) == std::string::npos) {
      return ::testing::AssertionFailure() << status.message();
    }
    return ::testing::AssertionSuccess();
  };
  const Coder coder{4, 2};
  EXPECT_TRUE(decodes_to(concat({varint(5), varint(0), lone(1, 1), varint(12), state}),
                         Script(5, Item{false, 0, 0}), coder, kVersion7));
  EXPECT_TRUE(decodes_to(concat({varint(5), varint(0), dense({0, 0, 7}), varint(12), state}),
                         Script(5, Item{false, 0, 2}), coder, kVersion7));
  EXPECT_TRUE(rejected_with(concat({varint(5), varint(0), lone(3, 1), varint(12), state}),
                            "context 2 out of range"));
  EXPECT_TRUE(rejected_with(concat({varint(5), varint(0), lone(1, 5), varint(12), state}),
                            "symbol 4 out of range in context 0"));
  EXPECT_TRUE(
      rejected_with(concat({varint(5), varint(0), dense({1, 1, 1, 1, 1}), varint(12), state}),
                    "5 symbols in context 0, alphabet 4"));
  EXPECT_TRUE(rejected_with(concat({varint(5), varint(0), dense({0, 0}), varint(12), state}),
                            "no symbols in context 0"));
  EXPECT_TRUE(rejected_with(concat({varint(5), varint(0), dense({1}, 33), varint(12), state}),
                            "bad weight code 32"));
  EXPECT_TRUE(
      rejected_with(concat({varint(5), varint(0), dense({uint64_t{1} << 32}), varint(12), state}),
                    "weight out of range in context 0"));
  EXPECT_TRUE(rejected_with(concat({varint(5), varint(0), lone(1, 1, 1), varint(12), state}),
                            "nonzero padding after the frequency tables"));
  EXPECT_TRUE(rejected_with(concat({varint(5), varint(0), lone(1, 1), varint(11), state}),
                            "11 rANS bytes, "));
  EXPECT_TRUE(rejected_with(concat({varint(5),
                                    varint(0),
                                    lone(1, 1),
                                    varint(12),
                                    {0, 0, 0x80, 0, 0xff, 0xff, 0x7f, 0, 0, 0, 0x80, 0}}),
                            "initial rANS state out of range"));
  EXPECT_TRUE(rejected_with(concat({varint(5), varint(3), lone(1, 1), varint(12), state, {8}}),
                            "nonzero padding after the raw bits"));
  // Context 1 shares context 0's table; then a context naming a table not yet defined.
  TableBits shared;
  shared.gamma(2);
  shared.gamma(1);
  shared.gamma(1);
  shared.put(1, 1);
  shared.gamma(2);  // symbols 1 and 2
  shared.gamma(2);
  shared.gamma(1);
  shared.gamma(1);  // order 0; weights 3 and 1
  shared.gamma(3);
  shared.gamma(1);
  shared.gamma(1);  // context 1
  shared.gamma(2);  // table 0
  ASSERT_TRUE(init_on(concat({varint(0), varint(0)}), &dec).ok());
  Status status =
      init_on(concat({varint(3), varint(0), shared.bytes, varint(13), state, {0}}), &dec);
  EXPECT_TRUE(status.ok()) << status.message();
  TableBits dangling;
  dangling.gamma(1);
  dangling.gamma(1);
  dangling.gamma(3);  // table 1
  EXPECT_TRUE(rejected_with(concat({varint(5), varint(0), dangling.bytes}),
                            "table 1 named in context 0, only 0 defined"));
  TableBits too_many;
  too_many.gamma(3);  // three contexts in a coder of two
  EXPECT_TRUE(rejected_with(concat({varint(5), varint(0), too_many.bytes}),
                            "3 contexts declared, the coder has 2"));
}

}  // namespace entropy_test
}  // namespace
}  // namespace osteon::detail
