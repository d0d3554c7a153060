// HugeVector / huge_allocate: blocks of 2 MiB and more come from their own 2 MiB-aligned mappings (Linux,
// outside sanitizer builds), smaller ones from operator new; either way the memory holds what is written,
// survives growth and copies, and is given back whole.
#include "multitri/huge_pages.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstddef>
#include <numeric>

namespace varmesh {
namespace {

constexpr std::size_t kHuge = std::size_t{2} << 20;

bool sanitized() {
#if defined(__SANITIZE_ADDRESS__)
  return true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
  return true;
#else
  return false;
#endif
#else
  return false;
#endif
}

TEST(HugePages, BlocksAroundTheThresholdHoldTheirBytes) {
  for (std::size_t bytes : {std::size_t{1}, std::size_t{4096}, kHuge - 8, kHuge, kHuge + 1, 3 * kHuge + 12345}) {
    auto* p = static_cast<unsigned char*>(huge_allocate(bytes));
    ASSERT_NE(p, nullptr);
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(p) % alignof(std::max_align_t), 0u) << bytes;
#if defined(__linux__)
    if (bytes >= kHuge && !sanitized()) {
      EXPECT_EQ(reinterpret_cast<std::uintptr_t>(p) % kHuge, 0u) << bytes;
    }
#endif
    for (std::size_t i = 0; i < bytes; i += 997) p[i] = static_cast<unsigned char>(i * 31u + 7u);
    p[bytes - 1] = 0xA5;
    for (std::size_t i = 0; i + 1 < bytes; i += 997) ASSERT_EQ(p[i], static_cast<unsigned char>(i * 31u + 7u)) << bytes;
    EXPECT_EQ(p[bytes - 1], 0xA5);
    huge_deallocate(p, bytes);
  }
}

TEST(HugePages, VectorsGrowCopyAndCompare) {
  HugeVector<std::uint32_t> v;
  for (std::uint32_t i = 0; i < 1'500'000; ++i) v.push_back(i * 7u);  // crosses the 2 MiB threshold while growing
  HugeVector<std::uint32_t> w = v;
  EXPECT_EQ(w, v);
  w.resize(10);
  w.shrink_to_fit();
  EXPECT_EQ(w.size(), 10u);
  for (std::uint32_t i = 0; i < 10; ++i) EXPECT_EQ(w[i], i * 7u);
  const std::uint64_t sum = std::accumulate(v.begin(), v.end(), std::uint64_t{0});
  EXPECT_EQ(sum, 7ull * (1'500'000ull * 1'499'999ull / 2));
}

}  // namespace
}  // namespace varmesh
