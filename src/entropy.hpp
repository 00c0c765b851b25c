// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <bit>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "byte_io.hpp"
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

class SymbolEncoder {
 public:
  /// alphabet: 2..4096 symbols; contexts: 1..4096.
  SymbolEncoder(uint32_t alphabet, uint32_t contexts);

  /// Queues one symbol (< alphabet) coded with context `context` (< contexts).
  void put(uint32_t context, uint32_t symbol);
  /// Queues `count` (0..32) raw bits of `value`, stored uncompressed in the bit stream.
  void put_bits(uint32_t value, int count);

  size_t symbol_count() const { return queued_.size(); }

  /// Appends the section: its layout is in docs/FORMAT.md ("Symbol section"). Frequencies are
  /// measured per context over the queued symbols; contexts with few symbols may share a table
  /// where that codes smaller. O(symbols + used contexts * alphabet), plus a bounded table-merging
  /// search (a few ms on small meshes; at most ~100 ms for thousands of sparse contexts).
  void append_to(std::vector<uint8_t>* out) const;

 private:
  uint32_t alphabet_;
  uint32_t contexts_;
  std::vector<uint32_t> queued_;  // (context << 12 | symbol) per symbol, in put order
  std::vector<uint8_t> bits_;     // raw bit stream, LSB-first
  uint64_t bit_count_ = 0;
};

class SymbolDecoder {
 public:
  /// Reads a section written by SymbolEncoder::append_to with the same alphabet and contexts.
  /// `what` names the section in messages ("connectivity", "geometry"). Errors: truncated or
  /// inconsistent tables, counts beyond the bytes that remain.
  /// Allocates 4096 slots (24 KiB) per table in the section and 16 KiB of context index; the
  /// table block spends at least 4 bits on each table, so hostile bytes buy at most 48 KiB per
  /// table byte (and never more than 4096 tables).
  /// Known approximation: symbols of a single-symbol context cost no bits, so their number cannot
  /// be bounded by the section's size (it is capped at 2^32 - 1): callers compare symbols_left()
  /// with the count their own header promises.
  Status init(ByteReader& in, uint32_t alphabet, uint32_t contexts, const std::string& source,
              const std::string& what);

  /// The next symbol of `context`. On a corrupt or exhausted stream it returns 0 and ok() turns
  /// false; callers check ok() at least once at the end (and may check sooner to stop early).
  /// O(1): one table lookup, a multiply and at most two bytes of renormalisation.
  uint32_t get(uint32_t context);
  /// The next `count` (0..32) raw bits.
  uint32_t get_bits(int count);

  bool ok() const { return ok_; }
  /// Symbols still to be decoded (for bounds: a decoder never asks for more than were coded).
  size_t symbols_left() const { return spare_ + budget_; }

  /// After the last get/get_bits: checks that every symbol and raw bit was read, that the rANS
  /// state is back at the encoder's initial state and that every rANS byte was consumed, which
  /// catches most corruption that get() alone cannot see. Errors name `source`, `what` and the
  /// byte offset of the section's rANS or raw-bit bytes.
  Status finish(const std::string& source, const std::string& what) const;

 private:
  static constexpr uint32_t kProbBits = 12;
  static constexpr uint32_t kProbScale = 1u << kProbBits;  // frequencies sum to this
  static constexpr uint32_t kRansLow = 1u << 23;           // state in [kRansLow, 2^31)
  static constexpr uint32_t kNoTable = 0xffffffffu;
  static constexpr uint32_t kMaxContexts = 4096;

  /// One of the 4096 slots of a context's table: the symbol owning the slot, its frequency and
  /// the slot's offset from the symbol's first slot, so a decode step needs one lookup.
  struct Slot {
    uint16_t symbol;
    uint16_t freq;  // 1..4096
    uint16_t bias;  // slot - start
  };

  uint32_t get_slow(uint32_t context);
  uint32_t get_bits_slow(int count);
  uint32_t fail() {
    ok_ = false;
    return 0;
  }

  std::vector<Slot> slots_;         // kProbScale per present context
  std::vector<uint32_t> table_of_;  // kMaxContexts: a context's first slot, or kNoTable
  uint32_t state_ = 0;
  // Renormalisation bytes, read forwards: data_ is the first (after the initial state).
  const uint8_t* data_ = nullptr;
  const uint8_t* cur_ = nullptr;
  const uint8_t* end_ = nullptr;
  // Symbols left = budget_ + spare_. The next budget_ symbols may take get()'s fast path: each
  // reads at most two bytes, and 2 * budget_ <= end_ - cur_. get_slow() refills it from spare_.
  size_t budget_ = 0;
  size_t spare_ = 0;
  const uint8_t* bits_ = nullptr;
  uint64_t bit_size_ = 0;   // in bits
  uint64_t bit_bytes_ = 0;  // (bit_size_ + 7) / 8
  uint64_t bit_pos_ = 0;
  size_t rans_at_ = 0;  // byte offsets in the reader, for messages
  size_t bits_at_ = 0;
  bool ok_ = false;
};

// The hot paths, inline: decoding a mesh calls them a few million times. Two well-predicted
// branches send the rare cases (the stream's last bytes, an exhausted or corrupt stream, an
// absent context) to the checked get_slow(); the common case is one lookup, a multiply and a
// byte-wise renormalisation.

inline uint32_t SymbolDecoder::get(uint32_t context) {
  assert(context < kMaxContexts);
  if (budget_ == 0) [[unlikely]]
    return get_slow(context);
  const uint32_t table = table_of_[context & (kMaxContexts - 1)];
  if (table == kNoTable) [[unlikely]]
    return get_slow(context);
  --budget_;
  const uint32_t x = state_;
  const Slot& slot = slots_[table + (x & (kProbScale - 1))];
  uint32_t y = slot.freq * (x >> kProbBits) + slot.bias;  // >= 2^11
  if (y < kRansLow) {
    y = (y << 8) | *cur_++;
    if (y < kRansLow) y = (y << 8) | *cur_++;
  }
  state_ = y;
  return slot.symbol;
}

inline uint32_t SymbolDecoder::get_bits(int count) {
  assert(count >= 0 && count <= 32);
  const uint64_t byte = bit_pos_ >> 3;
  if (bit_pos_ + static_cast<uint64_t>(count) > bit_size_ || byte + 8 > bit_bytes_) [[unlikely]] {
    return get_bits_slow(count);
  }
  const uint64_t word = ByteReader::load<uint64_t>(bits_ + byte, std::endian::little);
  const uint64_t value = (word >> (bit_pos_ & 7)) & ((uint64_t{1} << count) - 1);
  bit_pos_ += static_cast<uint64_t>(count);
  return static_cast<uint32_t>(value);
}

}  // namespace osteon::detail
