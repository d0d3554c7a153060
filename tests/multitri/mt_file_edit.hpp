#pragma once
// Editing .vrm files in tests: the offsets and checksums of the layout documented in multitri/mt_io.hpp,
// written here again from that description (not taken from the reader), so that a test can cut, damage or
// edit a file and re-seal it.
#include <cstddef>
#include <cstdint>
#include <string>

namespace varmesh::testing {

// Version 2 header fields.
inline constexpr std::size_t kVrmVersionAt = 8, kVrmCountsAt = 12, kVrmSizeAt = 24, kVrmHeaderSumAt = 32,
                             kVrmHeaderBytes = 40;

inline std::uint64_t fnv1a64_of(const std::string& b, std::size_t n) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (std::size_t i = 0; i < n; ++i) {
    h ^= static_cast<unsigned char>(b[i]);
    h *= 0x100000001b3ull;
  }
  return h;
}

inline void put_le(std::string& b, std::size_t at, std::uint64_t v, int width) {
  for (int k = 0; k < width; ++k) b[at + static_cast<std::size_t>(k)] = static_cast<char>(v >> (8 * k));
}

inline std::uint64_t get_le(const std::string& b, std::size_t at, int width) {
  std::uint64_t v = 0;
  for (int k = 0; k < width; ++k)
    v |= std::uint64_t{static_cast<unsigned char>(b[at + static_cast<std::size_t>(k)])} << (8 * k);
  return v;
}

/// Rewrites the trailing checksum over everything before it.
inline void reseal(std::string& b) { put_le(b, b.size() - 8, fnv1a64_of(b, b.size() - 8), 8); }

/// Rewrites the version-2 header checksum, then the trailing one (which covers the header too).
inline void reseal_all(std::string& b) {
  put_le(b, kVrmHeaderSumAt, fnv1a64_of(b, kVrmHeaderSumAt), 8);
  reseal(b);
}

/// The version-1 file of the same MT: no size and no header checksum (bytes 24 .. 39), version 1.
inline std::string as_version_1(std::string b) {
  b.erase(kVrmSizeAt, kVrmHeaderBytes - kVrmSizeAt);
  put_le(b, kVrmVersionAt, 1, 4);
  reseal(b);
  return b;
}

}  // namespace varmesh::testing
