// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <algorithm>
#include <bit>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <string>
#include <vector>

#include "codec/code_placement.hpp"
#include "core/byte_io.hpp"
#include "osteon/status.hpp"

// Entropy coding for the codec's symbol streams: rANS (Duda 2013) with one frequency table per
// context (contexts may share one), plus a raw bit stream for bits not worth modelling, in one
// section.
//
// Usage (encoder): SymbolEncoder enc(alphabet, contexts); enc.put(ctx, sym) ... enc.put_bits(v, n)
// ...; enc.append_to(&out). Usage (decoder): SymbolDecoder dec; dec.init(reader, alphabet,
// contexts, "connectivity") ; dec.get(ctx) ... dec.get_bits(n) ...; then dec.ok() must be true.
// The decoder must call get/get_bits in exactly the encoder's put/put_bits order with the same
// contexts. Contexts are chosen by the caller from data both sides already have (previous
// symbols, valences, ...), so the model adapts to each mesh: tables are measured on the stream
// being coded and sent with it (semi-static adaptation), which keeps decoding a table lookup.

namespace osteon::detail {

/// The rANS states live in [kRansLow, 2^31); the encoder starts a stream's last section there.
inline constexpr uint32_t kRansLow = 1u << 23;

/// A message with numbers in it: each '%' of `pattern` becomes the next of `numbers`, in
/// decimal. One small function for the decoder's many error messages, where string
/// concatenations would inline several calls each (the WebAssembly decoder's size is budgeted).
std::string message(const char* pattern, std::initializer_list<uint64_t> numbers);
/// The decoders' kInvalidData error: "source: " + prefix + message(first + second, numbers),
/// at byte `at`. Out of line, so that each of the decoder's error returns is a call, not the
/// strings' code again (the WebAssembly decoder's download is budgeted).
Status invalid_data(const std::string& source, size_t at, const char* prefix, const char* first,
                    std::initializer_list<uint64_t> numbers = {}, const char* second = "");

/// A section's tables, planned from its symbols' counts: each used context's row (row[context],
/// or ~0u), the row whose table each row codes with, per (group row, symbol) the frequency and
/// cumulative start of the rANS coder, and the table block's bytes. From plan_symbols() also the
/// bits the section will spend on them (table block plus each symbol's log2(4096 / frequency); not
/// its few bytes of counts and final states, nor its raw bits).
struct SymbolPlan {
  std::vector<uint32_t> row;
  std::vector<uint32_t> group;
  std::vector<uint16_t> freq;
  std::vector<uint16_t> start;
  std::vector<uint8_t> block;
  double bits = 0;
};

/// The plan SymbolEncoder would make for symbols with these counts (`counts[context * alphabet +
/// symbol]`, `contexts` rows), `order` listing the contexts that occur in the order of their first
/// symbol: for sizing a stream from its counts alone, without queueing its symbols.
SymbolPlan plan_symbols(const std::vector<uint32_t>& counts, const std::vector<uint32_t>& order,
                        uint32_t contexts, uint32_t alphabet);

class SymbolEncoder {
 public:
  /// alphabet: 2..4096 symbols; contexts: 1..4096.
  SymbolEncoder(uint32_t alphabet, uint32_t contexts);

  /// Room for `symbols` more queued symbols.
  void reserve(size_t symbols) { queued_.reserve(queued_.size() + symbols); }
  /// Queues one symbol (< alphabet) coded with context `context` (< contexts). Not after
  /// use_plan(), whose plan is for the symbols queued before it.
  void put(uint32_t context, uint32_t symbol) {
    assert(context < contexts_ && symbol < alphabet_);
    assert(queued_.size() < UINT32_MAX && !plan_.has_value());
    queued_.push_back(context << kContextShift | symbol);
  }
  /// Queues `count` (0..32) raw bits of `value`, stored uncompressed in the bit stream. Not
  /// after use_plan() either.
  void put_bits(uint32_t value, int count) {
    assert(count >= 0 && count <= 32 && !plan_.has_value());
    const uint64_t bits = value & ((uint64_t{1} << count) - 1);
    pending_ |= bits << pending_bits_;  // pending_bits_ < 32, so the bits fit in 64
    pending_bits_ += count;
    bit_count_ += static_cast<uint64_t>(count);
    if (pending_bits_ >= 32) {  // a whole word out
      words_.push_back(static_cast<uint32_t>(pending_));
      pending_ >>= 32;
      pending_bits_ -= 32;
    }
  }

  static constexpr uint32_t kContextShift = 12;  // a queued symbol is context << 12 | symbol

  size_t symbol_count() const { return queued_.size(); }
  /// The symbols queued so far, as (context << kContextShift | symbol), and the raw bits.
  const std::vector<uint32_t>& queued() const { return queued_; }
  uint64_t raw_bit_count() const { return bit_count_; }

  /// Appends the section, in stream version 8's layout (docs/FORMAT.md, "Symbol section"): the
  /// caller's format implies the symbol count, and nothing may follow the section in its
  /// enclosing section (the rANS bytes end where the raw bits begin). Frequencies are
  /// measured per context over the queued symbols; contexts with few symbols may share a table
  /// where that codes smaller. O(symbols + used contexts * alphabet), plus a bounded table-merging
  /// search (a few ms on small meshes; at most ~100 ms for thousands of sparse contexts).
  /// Chained sections (SectionLayout): `end_state` is where state N mod S ends in decoding
  /// (kRansLow for a stream's last section, otherwise the next section's first state, which its
  /// own append_to returned), and a `chained` section (not the stream's first) does not write its
  /// state 0. Returns the section's first state 0 (`end_state` if it has no symbols).
  uint32_t append_to(std::vector<uint8_t>* out, uint32_t end_state = kRansLow,
                     bool chained = false) const;
  /// Codes the queued symbols with `plan`, which plan_symbols() made from their counts (the
  /// plan append_to would make itself), instead of planning again.
  void use_plan(SymbolPlan plan);

 private:
  SymbolPlan plan() const;  // the plan of the queued symbols

  uint32_t alphabet_;
  uint32_t contexts_;
  std::vector<uint32_t> queued_;  // (context << 12 | symbol) per symbol, in put order
  std::vector<uint32_t> words_;   // raw bit stream, LSB-first, its whole 32-bit words
  uint64_t pending_ = 0;          // the bits after words_ (fewer than 32), lowest first
  int pending_bits_ = 0;
  uint64_t bit_count_ = 0;
  std::optional<SymbolPlan> plan_;  // from use_plan(); otherwise append_to plans
};

/// A symbol section's layout (docs/FORMAT.md, "Symbol section"), by the stream's version. Up to
/// version 7 a section states its symbol count and its rANS byte count, and has three rANS states.
/// From version 8 (kCompactSectionVersion) the enclosing section knows the symbol count, the
/// symbol section runs to the enclosing section's end (the rANS bytes are what the raw bits
/// leave), and a short section has one state.
///
/// From version 8 the sections of a stream also form one chain: a section's state 0 starts where
/// the section before it left the state it decodes its last symbols with (that section's
/// last_state(), the encoder's state N mod S), so only the stream's first section writes its
/// state 0, and only the last section's states must all end at 2^23.
struct SectionLayout {
  uint32_t version;
  uint64_t symbols;  // version 8: the symbol count; before it, ignored (the section says)
  // Version 8: the section before's last_state(), this section's state 0, or 0 for a stream's
  // first section (which writes its own).
  uint32_t first_state = 0;
  // Version 8: another section follows, which starts where this one's state 0 ends.
  bool more = false;
};
constexpr uint32_t kCompactSectionVersion = 8;

class SymbolDecoder {
 public:
  /// Reads a section written by SymbolEncoder::append_to (version 8), or by an earlier encoder
  /// (`layout`), with the same alphabet and contexts. In version 8 `in` ends where the section
  /// does. `what` names the section in messages ("connectivity", "geometry"). Errors: truncated
  /// or inconsistent tables, counts beyond the bytes that remain.
  /// Memory: for alphabets up to kSmallAlphabet, 16 bytes per context (64 KiB for 4096); for
  /// larger ones 4 * kBuckets bytes per context and 4 per present symbol of each table (the
  /// table block spends at least one bit on a symbol).
  /// Known approximation: symbols of a single-symbol context cost no bits, so their number cannot
  /// be bounded by the section's size (it is capped at 2^32 - 1): callers compare symbols_left()
  /// with the count their own header promises.
  Status init(ByteReader& in, uint32_t alphabet, uint32_t contexts, SectionLayout layout,
              const std::string& source, const std::string& what);

  /// The decoder's moving parts: the rANS state, the next rANS byte, the raw-bit position. A hot
  /// loop copies them into a local variable (cursor()), decodes through get(Cursor&, ...) and
  /// get_bits(Cursor&, ...), and hands them back (resume()) before ok(), symbols_left() or
  /// finish(): a local whose address never escapes stays in registers, where the decoder's own
  /// members would be reloaded after every store the compiler cannot tell apart from them.
  struct Cursor {
    // The interleaved rANS states, each in [2^23, 2^31): x0 decodes the next symbol, then the
    // states rotate (x0 <- x1 <- x2 <- x0's successor), so symbol i is state i mod 3's. Three
    // chains of dependent steps instead of one: a step's table search and multiply overlap the
    // next steps' (when the caller's contexts allow; see get3()). (Kept apart from each other:
    // adjacent, the compiler rotates them as one vector, which chains every step to the last.)
    // A short section of version 8 has x0 alone (x1 = x2 = 2^23 throughout): each step keeps
    // its new state in x0 instead of rotating (advance()).
    uint32_t x0;
    const uint8_t* cur;  // the next renormalisation byte
    uint32_t x1;
    // Symbols left = budget + spare. The next `budget` symbols may take get()'s fast path: each
    // reads at most two bytes, and 2 * budget <= end_ - cur. The slow path refills it.
    size_t budget;
    uint32_t x2;
    size_t spare;
    uint64_t bit_pos;  // in the raw bits
    bool ok;
  };
  Cursor cursor() const { return hot_; }
  void resume(const Cursor& cursor) { hot_ = cursor; }

  /// The next symbol of `context`. On a corrupt or exhausted stream it returns 0 and ok() turns
  /// false; callers check ok() at least once at the end (and may check sooner to stop early).
  /// O(1): a search of the context's cumulative frequencies (a few compares), a multiply and at
  /// most two bytes of renormalisation.
  uint32_t get(uint32_t context) { return get(hot_, context); }
  uint32_t get(Cursor& cursor, uint32_t context) const;
  /// The next three symbols, of contexts context[0..2]: the same as three get() calls, but the
  /// three table searches and multiplies run side by side (each symbol of three has its own rANS
  /// state), where a loop of get() calls may not overlap them.
  void get3(Cursor& cursor, const uint32_t context[3], uint32_t symbol[3]) const;
  /// The next `count` (0..32) raw bits.
  uint32_t get_bits(int count) { return static_cast<uint32_t>(get_bits(hot_, count)); }
  /// The next `count` (0..56) raw bits: bit j of the result is the j-th.
  uint64_t get_bits(Cursor& cursor, int count) const;

  bool ok() const { return hot_.ok; }
  /// After finish(): the state the cursor holds as x0, where the next section of a version-8
  /// stream starts (the encoder's state N mod S, which it started there).
  uint32_t last_state() const { return hot_.x0; }
  /// Symbols still to be decoded (for bounds: a decoder never asks for more than were coded).
  size_t symbols_left() const { return hot_.spare + hot_.budget; }

  /// After the last get/get_bits: checks that every symbol and raw bit was read, that the rANS
  /// state is back at the encoder's initial state and that every rANS byte was consumed, which
  /// catches most corruption that get() alone cannot see. Errors name `source`, `what` and the
  /// byte offset of the section's rANS or raw-bit bytes.
  Status finish(const std::string& source, const std::string& what) const;

 private:
  static constexpr uint32_t kProbBits = 12;
  static constexpr uint32_t kProbScale = 1u << kProbBits;  // frequencies sum to this
  static constexpr uint32_t kMaxContexts = 4096;

  // A decode step searches the context's table for the symbol owning the slot x mod 2^12.
  //
  // Alphabets up to kSmallAlphabet (the connectivity's 5 CLERS symbols): each context has its own
  // row of 8 cumulative frequencies, cum[s] = start of symbol s (cum[0] = 0, an absent symbol an
  // empty range, cum[alphabet..7] = 2^12); the symbol is the number of cum[1..6] <= slot: six
  // independent compares, no table of slots. A context without a table has cum[0] = kAbsent.
  static constexpr uint32_t kSmallAlphabet = 7;
  static constexpr uint16_t kAbsent = 0xffff;
  //
  // Larger alphabets: a table is one entry per present symbol, start | symbol << 16 with
  // increasing starts, and a sentinel (start 2^12), led by kBuckets buckets that name, for each
  // 2^12 / kBuckets slots, the entry owning the bucket's first slot (16 bits, relative to the
  // table's first entry). From there the search steps forward while the next entry starts at or
  // below the slot: rarely, since only the rare symbols' short ranges put several boundaries in
  // one bucket. A context names its table by where its buckets and its entries begin (kNoTable:
  // none); that lookup depends on the context only, so a caller whose contexts are known early
  // keeps it off the chain of dependent steps.
  static constexpr uint32_t kBucketBits = 6;
  static constexpr uint32_t kBuckets = 1u << kBucketBits;
  static constexpr uint32_t kNoTable = 0xffffffffu;
  struct TableRef {
    uint32_t buckets;  // index of its first bucket in buckets_, or kNoTable
    uint32_t entries;  // index of its first entry in entries_
  };

  bool find(uint32_t context, uint32_t slot, uint32_t* symbol, uint32_t* start,
            uint32_t* freq) const;
  static uint32_t renormalize(uint32_t y, const uint8_t*& cur);
  /// A step's new state y, renormalised: kept in x0 where the section has one state, otherwise
  /// rotated in behind x1 and x2 (the next symbol is x1's).
  void advance(Cursor& c, uint32_t y) const {
    if (single_) [[unlikely]] {
      c.x0 = y;
      return;
    }
    c.x0 = c.x1;
    c.x1 = c.x2;
    c.x2 = y;
  }

  /// A cursor whose rANS step failed or read past the stream (for the slow paths).
  struct Step {
    Cursor cursor;
    uint64_t value;
  };
  Step get_slow(Cursor cursor, uint32_t context) const;
  void get3_slow(Cursor& cursor, const uint32_t context[3], uint32_t symbol[3]) const;
  Step get_bits_slow(Cursor cursor, int count) const;
  static Step failed(Cursor cursor) {
    cursor.ok = false;
    return {cursor, 0};
  }

  bool small_ = true;
  bool single_ = false;  // one rANS state (a short section of version 8)
  bool more_ = false;    // another section continues from the state left in x0 (version 8)
  uint32_t state_bytes_ = 12;
  uint32_t contexts_ = 0;
  std::vector<uint16_t> cum_;       // small alphabets: 8 per context
  std::vector<TableRef> table_of_;  // large alphabets: per context
  std::vector<uint16_t> buckets_;   // large alphabets: kBuckets per table
  std::vector<uint32_t> entries_;   // large alphabets: every table's entries and sentinel
  Cursor hot_{kRansLow, nullptr, kRansLow, 0, kRansLow, 0, 0, false};
  // Renormalisation bytes, read forwards: data_ is the first (after the initial state).
  const uint8_t* data_ = nullptr;
  const uint8_t* end_ = nullptr;
  const uint8_t* bits_ = nullptr;
  uint64_t bit_size_ = 0;   // in bits
  uint64_t bit_bytes_ = 0;  // (bit_size_ + 7) / 8
  size_t rans_at_ = 0;      // byte offsets in the reader, for messages
  size_t bits_at_ = 0;
};

// The hot paths, inline: decoding a mesh calls them a few million times. Well-predicted branches
// send the rare cases (the stream's last bytes, an exhausted or corrupt stream, an absent
// context) to the checked slow paths; the common case is a short search, a multiply and a
// byte-wise renormalisation.

inline bool SymbolDecoder::find(uint32_t context, uint32_t slot, uint32_t* symbol, uint32_t* start,
                                uint32_t* freq) const {
  if (small_) {
    const uint16_t* cum = &cum_[8 * size_t{context}];
    if (cum[0] == kAbsent) [[unlikely]]
      return false;
    uint32_t s = 0;
    for (int i = 1; i < 7; ++i) s += cum[i] <= slot ? 1 : 0;
    *symbol = s;
    *start = cum[s];
    *freq = cum[s + 1] - cum[s];
    return true;
  }
  const TableRef table = table_of_[context];
  if (table.buckets == kNoTable) [[unlikely]]
    return false;
  const uint32_t* e = entries_.data() + table.entries;
  uint32_t i = buckets_[table.buckets + (slot >> (kProbBits - kBucketBits))];
  while ((e[i + 1] & 0xffff) <= slot) ++i;
  *symbol = e[i] >> 16;
  *start = e[i] & 0xffff;
  *freq = (e[i + 1] & 0xffff) - *start;
  return true;
}

inline uint32_t SymbolDecoder::renormalize(uint32_t y, const uint8_t*& cur) {
  // Without a branch (whether a step reads a byte is a coin toss the branch predictor loses):
  // y >= 2^11 needs (y < 2^23) + (y < 2^15) bytes, and the budget guarantees that two are
  // there. (The shifts are those comparisons for y < 2^31, spelled so that the compiler does
  // not turn them back into a branch.)
  const uint32_t n = ((y - kRansLow) >> 31 << 3) + ((y - (kRansLow >> 8)) >> 31 << 3);
  const uint32_t bytes = uint32_t{cur[0]} << 8 | cur[1];
  cur += n >> 3;
  return static_cast<uint32_t>(uint64_t{y} << n | bytes >> (16 - n));
}

inline uint32_t SymbolDecoder::get(Cursor& c, uint32_t context) const {
  assert(context < kMaxContexts);
  const uint32_t x = c.x0;
  const uint32_t slot = x & (kProbScale - 1);
  uint32_t symbol, start, freq;
  if (c.budget == 0 || context >= contexts_ || !find(context, slot, &symbol, &start, &freq))
      [[unlikely]] {
    const Step step = get_slow(c, context);
    c = step.cursor;
    return static_cast<uint32_t>(step.value);
  }
  --c.budget;
  advance(c, renormalize(freq * (x >> kProbBits) + slot - start, c.cur));
  return symbol;
}

inline void SymbolDecoder::get3(Cursor& c, const uint32_t context[3], uint32_t symbol[3]) const {
  const uint32_t slot[3] = {c.x0 & (kProbScale - 1), c.x1 & (kProbScale - 1),
                            c.x2 & (kProbScale - 1)};
  uint32_t start[3], freq[3];
  if (c.budget < 3 || single_ || std::max({context[0], context[1], context[2]}) >= contexts_ ||
      !find(context[0], slot[0], &symbol[0], &start[0], &freq[0]) ||
      !find(context[1], slot[1], &symbol[1], &start[1], &freq[1]) ||
      !find(context[2], slot[2], &symbol[2], &start[2], &freq[2])) [[unlikely]] {
    get3_slow(c, context, symbol);
    return;
  }
  c.budget -= 3;
  // The three steps' states are x0, x1 and x2; after three steps each state is back in place.
  const uint32_t y0 = freq[0] * (c.x0 >> kProbBits) + slot[0] - start[0];
  const uint32_t y1 = freq[1] * (c.x1 >> kProbBits) + slot[1] - start[1];
  const uint32_t y2 = freq[2] * (c.x2 >> kProbBits) + slot[2] - start[2];
  c.x0 = renormalize(y0, c.cur);
  c.x1 = renormalize(y1, c.cur);
  c.x2 = renormalize(y2, c.cur);
}

inline uint64_t SymbolDecoder::get_bits(Cursor& c, int count) const {
  assert(count >= 0 && count <= 56);
  const uint64_t byte = c.bit_pos >> 3;
  if (c.bit_pos + static_cast<uint64_t>(count) > bit_size_ || byte + 8 > bit_bytes_) [[unlikely]] {
    const Step step = get_bits_slow(c, count);
    c = step.cursor;
    return step.value;
  }
  const uint64_t word = ByteReader::load<uint64_t>(bits_ + byte, std::endian::little);
  const uint64_t value = (word >> (c.bit_pos & 7)) & ((uint64_t{1} << count) - 1);
  c.bit_pos += static_cast<uint64_t>(count);
  return value;
}

}  // namespace osteon::detail
