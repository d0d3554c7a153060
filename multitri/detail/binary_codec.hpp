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
#include <vector>

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
  /// Appends the checksum of everything written so far.
  void finish_with_checksum() { le(fnv1a64(buf_.data(), buf_.size())); }
  std::string& str() { return buf_; }

 private:
  std::string buf_;
};

class Reader {
 public:
  Reader(std::string_view data, std::string file) : data_(data), file_(std::move(file)) {}
  std::uint64_t offset() const noexcept { return pos_; }
  std::size_t remaining() const noexcept { return data_.size() - pos_; }
  [[noreturn]] void fail(const std::string& reason) const { throw IoError(file_, reason, IoError::kNoLine, pos_); }
  void need(std::size_t n, const char* what) const {
    if (n > remaining()) fail(std::string("truncated: ") + what + " needs " + std::to_string(n) + " bytes, " + std::to_string(remaining()) + " left");
  }
  template <class T> T le(const char* what) {
    need(sizeof(T), what);
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < sizeof(T); ++i) v |= static_cast<std::uint64_t>(static_cast<unsigned char>(data_[pos_ + i])) << (8 * i);
    pos_ += sizeof(T);
    return static_cast<T>(v);
  }
  float f32(const char* what) {
    const float v = std::bit_cast<float>(le<std::uint32_t>(what));
    if (!std::isfinite(v)) {
      pos_ -= 4;
      fail(std::string(what) + ": not a finite number");
    }
    return v;
  }
  /// A count of items of `item_bytes` each that must fit in the rest of the file (checked before anything
  /// is allocated from it).
  std::uint32_t count(const char* what, std::size_t item_bytes) {
    const std::uint64_t at = pos_;
    const std::uint32_t n = le<std::uint32_t>(what);
    if (item_bytes > 0 && static_cast<std::uint64_t>(n) * item_bytes > remaining()) {
      pos_ = at;
      fail(std::string(what) + ": count " + std::to_string(n) + " larger than the file can hold");
    }
    return n;
  }
  /// Verifies the trailing FNV-1a 64 checksum over everything before it; call when positioned on it.
  /// After check_checksum_up_front() succeeded, a parse that ends exactly on the checksum needs no second pass.
  void check_checksum() {
    if (checked_up_front_ && pos_ + 8 == data_.size()) {
      pos_ += 8;
      return;
    }
    const std::uint64_t expect = fnv1a64(data_.data(), pos_);
    const std::uint64_t got = le<std::uint64_t>("checksum");
    if (got != expect) {
      pos_ -= 8;
      fail("checksum mismatch (file corrupt)");
    }
    if (remaining() != 0) fail("trailing bytes after the checksum");
  }
  /// Verifies the checksum stored in the last 8 bytes before parsing anything (so that corruption is
  /// reported as such, not as a confusing parse error).
  void check_checksum_up_front() {
    if (data_.size() < 8) throw IoError(file_, "truncated: shorter than a checksum", IoError::kNoLine, data_.size());
    const std::size_t body = data_.size() - 8;
    std::uint64_t got = 0;
    for (std::size_t i = 0; i < 8; ++i) got |= static_cast<std::uint64_t>(static_cast<unsigned char>(data_[body + i])) << (8 * i);
    if (got != fnv1a64(data_.data(), body)) throw IoError(file_, "checksum mismatch (file corrupt or truncated)", IoError::kNoLine, body);
    checked_up_front_ = true;
  }

 private:
  std::string_view data_;
  std::string file_;
  std::size_t pos_ = 0;
  bool checked_up_front_ = false;
};

}  // namespace varmesh::detail
