// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "osteon/status.hpp"

// The one bounds-checked reader every parser goes through (STYLE habit 5), and the one writer every
// binary format is written with. Binary parsing uses ByteReader; text formats use TextReader,
// which tracks line numbers for messages. Neither ever reads past the end: every read returns
// false instead, and the caller turns that into a Status. ByteWriter appends little-endian values
// and LEB128 varints (docs/FORMAT.md "Conventions") to a byte vector.

namespace osteon {

class ByteReader {
 public:
  ByteReader(const uint8_t* data, size_t size) : data_(data), size_(size) {}

  size_t offset() const { return offset_; }
  size_t size() const { return size_; }
  size_t remaining() const { return size_ - offset_; }
  const uint8_t* current() const { return data_ + offset_; }
  /// True when `count` items of `item_bytes` each fit in the bytes that remain (overflow-safe).
  bool fits(uint64_t count, uint64_t item_bytes) const {
    return item_bytes == 0 || count <= remaining() / item_bytes;
  }

  bool skip(size_t n) {
    if (n > remaining()) return false;
    offset_ += n;
    return true;
  }
  bool seek(size_t offset) {
    if (offset > size_) return false;
    offset_ = offset;
    return true;
  }
  bool read_bytes(void* out, size_t n) {
    if (n > remaining()) return false;
    std::memcpy(out, data_ + offset_, n);
    offset_ += n;
    return true;
  }
  template <class T>
  bool read_le(T* out) {
    return read_endian(out, std::endian::little);
  }
  template <class T>
  bool read_be(T* out) {
    return read_endian(out, std::endian::big);
  }
  template <class T>
  bool read_endian(T* out, std::endian order) {
    static_assert(std::is_trivially_copyable_v<T>);
    if (sizeof(T) > remaining()) return false;
    *out = load<T>(data_ + offset_, order);
    offset_ += sizeof(T);
    return true;
  }

  /// An unsigned LEB128 varint: 7 bits a byte, least significant first, high bit set on every
  /// byte but the last. False at the end of the bytes or for a value of more than 64 bits.
  bool read_varint(uint64_t* out) {
    uint64_t value = 0;
    for (int shift = 0; shift < 64; shift += 7) {
      uint8_t byte = 0;
      if (!read_le(&byte)) return false;
      if (shift == 63 && byte > 1) return false;  // more than 64 bits
      value |= static_cast<uint64_t>(byte & 0x7f) << shift;
      if ((byte & 0x80) == 0) {
        *out = value;
        return true;
      }
    }
    return false;
  }

  /// Loads a T stored in byte order `order` from unaligned memory.
  template <class T>
  static T load(const uint8_t* p, std::endian order) {
    uint8_t bytes[sizeof(T)];
    std::memcpy(bytes, p, sizeof(T));
    if (order != std::endian::native) {
      for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
    }
    T value;
    std::memcpy(&value, bytes, sizeof(T));
    return value;
  }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t offset_ = 0;
};

/// Appends to a byte vector it does not own: little-endian values, raw bytes and LEB128 varints,
/// the inverse of ByteReader's read_le, read_bytes and read_varint.
class ByteWriter {
 public:
  explicit ByteWriter(std::vector<uint8_t>* out) : out_(out) {}

  size_t size() const { return out_->size(); }

  void write_bytes(const void* data, size_t n) {
    const uint8_t* p = static_cast<const uint8_t*>(data);
    out_->insert(out_->end(), p, p + n);
  }
  template <class T>
  void write_le(T value) {
    static_assert(std::is_trivially_copyable_v<T>);
    uint8_t bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    if constexpr (std::endian::native == std::endian::big) {
      for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
    }
    write_bytes(bytes, sizeof(T));
  }
  void write_varint(uint64_t value) {
    while (value >= 0x80) {
      out_->push_back(static_cast<uint8_t>(value | 0x80));
      value >>= 7;
    }
    out_->push_back(static_cast<uint8_t>(value));
  }

 private:
  std::vector<uint8_t>* out_;
};

/// Line- and token-oriented reading of ASCII formats (OBJ, OFF, ASCII PLY/STL/VTK). Tokens are
/// separated by spaces, tabs and line ends; '\r' is whitespace. No allocation.
class TextReader {
 public:
  TextReader(const char* data, size_t size) : data_(data), size_(size) {}
  TextReader(const uint8_t* data, size_t size)
      : data_(reinterpret_cast<const char*>(data)), size_(size) {}

  size_t offset() const { return offset_; }
  size_t line() const { return line_; }
  size_t remaining() const { return size_ - offset_; }
  bool at_end() const { return offset_ >= size_; }
  /// "line 12" for messages.
  std::string where() const { return "line " + std::to_string(line_); }

  /// Skips spaces, tabs and '\r', but not newlines.
  void skip_blanks() {
    while (offset_ < size_ &&
           (data_[offset_] == ' ' || data_[offset_] == '\t' || data_[offset_] == '\r' ||
            data_[offset_] == '\f' || data_[offset_] == '\v'))
      ++offset_;
  }
  /// Skips all whitespace including newlines.
  void skip_whitespace() {
    while (offset_ < size_ && is_space(data_[offset_])) {
      if (data_[offset_] == '\n') ++line_;
      ++offset_;
    }
  }
  /// The next whitespace-separated token, possibly on a later line; empty at the end.
  std::string_view next_token() {
    skip_whitespace();
    return token_here();
  }
  /// The next token on the current line; empty at the end of the line.
  std::string_view next_token_on_line() {
    skip_blanks();
    return token_here();
  }
  /// The rest of the current line (without the line end), moving to the start of the next.
  std::string_view rest_of_line() {
    size_t start = offset_;
    while (offset_ < size_ && data_[offset_] != '\n') ++offset_;
    size_t end = offset_;
    if (offset_ < size_) {
      ++offset_;
      ++line_;
    }
    while (end > start && (data_[end - 1] == '\r' || data_[end - 1] == ' ')) --end;
    return {data_ + start, end - start};
  }
  void skip_line() { (void)rest_of_line(); }

  static bool is_space(char c) {
    return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v';
  }

 private:
  std::string_view token_here() {
    size_t start = offset_;
    while (offset_ < size_ && !is_space(data_[offset_])) ++offset_;
    return {data_ + start, offset_ - start};
  }

  const char* data_;
  size_t size_;
  size_t offset_ = 0;
  size_t line_ = 1;
};

/// A token from a file, fit for an error message: quoted, at most 32 characters, unprintable
/// bytes replaced by '?'.
inline std::string quote_token(std::string_view token) {
  std::string out = "'";
  for (size_t i = 0; i < token.size() && i < 32; ++i) {
    char c = token[i];
    out += (c >= 0x20 && c < 0x7f) ? c : '?';
  }
  if (token.size() > 32) out += "...";
  return out + "'";
}

/// Appends `value` in decimal. By hand, for messages: std::to_string would bring its tables into
/// the WebAssembly decoder's budgeted download.
inline void append_decimal(uint64_t value, std::string* out) {
  // Written from the end, then appended at once (the WebAssembly decoder then needs no
  // push_back).
  char digits[20];
  char* first = digits + sizeof digits;
  do {
    *--first = static_cast<char>('0' + value % 10);
    value /= 10;
  } while (value != 0);
  out->append(first, static_cast<size_t>(digits + sizeof digits - first));
}

/// "byte 84" for messages.
inline std::string at_byte(size_t offset) {
  std::string out = "byte ";
  append_decimal(offset, &out);
  return out;
}

}  // namespace osteon
