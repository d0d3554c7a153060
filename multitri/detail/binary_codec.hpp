#pragma once
// Little-endian binary encoding with bounds-checked decoding and an FNV-1a 64 checksum: the common layer of
// varmesh's versioned binary files (multitri/mt_io.hpp). A Reader never reads past its buffer: each read
// checks the remaining size first and throws IoError(file, reason, byte offset).
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

#include "multitri/errors.hpp"

namespace varmesh::detail {

/// FNV-1a, 64 bit (Fowler-Noll-Vo): simple, byte-order independent, good enough to detect corruption.
inline std::uint64_t fnv1a64(const void* data, std::size_t n, std::uint64_t h = 0xcbf29ce484222325ull) noexcept {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < n; ++i) {
    h ^= p[i];
    h *= 0x100000001b3ull;
  }
  return h;
}

/// The little-endian unsigned integer of sizeof(T) bytes at `p` (the caller checked that they exist).
template <class T> T load_le(const char* p) noexcept {
  static_assert(std::is_integral_v<T> && std::is_unsigned_v<T>);
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < sizeof(T); ++i) v |= static_cast<std::uint64_t>(static_cast<unsigned char>(p[i])) << (8 * i);
  return static_cast<T>(v);
}

class Writer {
 public:
  void bytes(const void* p, std::size_t n) { buf_.append(static_cast<const char*>(p), n); }
  template <class T> void le(T v) {
    static_assert(std::is_integral_v<T>);
    char b[sizeof(T)];
    for (std::size_t i = 0; i < sizeof(T); ++i) b[i] = static_cast<char>((static_cast<std::uint64_t>(v) >> (8 * i)) & 0xffu);
    buf_.append(b, sizeof(T));
  }
  /// Room for `n` more bytes (saves the reallocations of a large file).
  void reserve(std::size_t n) { buf_.reserve(buf_.size() + n); }
  void f32(float v) { le(std::bit_cast<std::uint32_t>(v)); }
  /// Appends the checksum (u64) of everything written so far.
  void append_checksum() { le(fnv1a64(buf_.data(), buf_.size())); }
  std::string& str() { return buf_; }

 private:
  std::string buf_;
};

/// Reads fields in order from `data`, the part of a file that may be parsed (the caller leaves out a trailing
/// checksum it verified). A read past the end throws IoError with `short_reason` as the start of its reason:
/// "truncated" when the reader has no other way to know the file's size, or what a shortfall means once the
/// size has been checked (the counts in the file disagree with it).
class Reader {
 public:
  Reader(std::string_view data, std::string file, std::string short_reason = "truncated")
      : data_(data), file_(std::move(file)), short_reason_(std::move(short_reason)) {}
  std::uint64_t offset() const noexcept { return pos_; }
  void seek(std::size_t pos) noexcept { pos_ = pos <= data_.size() ? pos : data_.size(); }
  std::size_t remaining() const noexcept { return data_.size() - pos_; }
  [[noreturn]] void fail(const std::string& reason) const { throw IoError(file_, reason, IoError::kNoLine, pos_); }
  void need(std::size_t n, const char* what) const {
    if (n > remaining())
      fail(short_reason_ + ": " + what + " needs " + std::to_string(n) + " bytes, " + std::to_string(remaining()) + " left");
  }
  template <class T> T le(const char* what) {
    need(sizeof(T), what);
    const T v = load_le<T>(data_.data() + pos_);
    pos_ += sizeof(T);
    return v;
  }
  float f32(const char* what) {
    const float v = std::bit_cast<float>(le<std::uint32_t>(what));
    if (!std::isfinite(v)) {
      pos_ -= 4;
      fail(std::string(what) + ": not a finite number");
    }
    return v;
  }
  /// A count of items of `item_bytes` each that must fit in the rest of the data (checked before anything
  /// is allocated from it).
  std::uint32_t count(const char* what, std::size_t item_bytes) {
    const std::uint64_t at = pos_;
    const std::uint32_t n = le<std::uint32_t>(what);
    if (item_bytes > 0 && static_cast<std::uint64_t>(n) * item_bytes > remaining()) {
      pos_ = at;
      fail(std::string(what) + " " + std::to_string(n) + " needs " + std::to_string(std::uint64_t{n} * item_bytes) +
           " bytes, " + std::to_string(remaining() - 4) + " left");
    }
    return n;
  }

 private:
  std::string_view data_;
  std::string file_;
  std::string short_reason_;
  std::size_t pos_ = 0;
};

}  // namespace varmesh::detail
