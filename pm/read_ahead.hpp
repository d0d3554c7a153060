#pragma once
// touch(x): a load whose value is dropped but which the compiler must still perform, for reading data a
// little before it is needed. Used where measured to beat __builtin_prefetch (a prefetch that misses the
// TLB may be dropped by the processor, a load is not): the QEM analysis's look-ahead and the hierarchy's
// validation. Internal to pm.

#include <cstdint>
#include <cstring>
#include <type_traits>

namespace varmesh::detail {

template <class T>
inline void touch(const T& x) noexcept {
  static_assert(std::is_trivially_copyable_v<T> && sizeof(T) <= sizeof(std::uint64_t));
  std::uint64_t bits = 0;
  std::memcpy(&bits, &x, sizeof(T));
#if defined(__GNUC__) || defined(__clang__)
  asm volatile("" : : "r"(bits));  // "uses" the value: the load cannot be removed
#else
  volatile std::uint64_t sink = bits;
  (void)sink;
#endif
}

}  // namespace varmesh::detail
