#pragma once
/// VARMESH_ASSERT(cond): checks a documented precondition of an unchecked accessor (the noexcept, O(1)
/// ones that take an element id, as std::vector::operator[] takes an index). On in debug builds and in
/// the sanitizer build (VARMESH_ENABLE_ASSERTS, set by -DVARMESH_SANITIZE=ON): a violation prints the file,
/// line and condition and aborts. Compiled out otherwise; release callers keep the unchecked speed.
#if defined(VARMESH_ENABLE_ASSERTS) || !defined(NDEBUG)
#include <cstdio>
#include <cstdlib>

namespace varmesh::detail {
[[noreturn]] inline void assert_failed(const char* condition, const char* file, int line) noexcept {
  std::fprintf(stderr, "%s:%d: varmesh: precondition violated: %s\n", file, line, condition);
  std::abort();
}
}  // namespace varmesh::detail

#define VARMESH_ASSERT(cond) ((cond) ? static_cast<void>(0) : ::varmesh::detail::assert_failed(#cond, __FILE__, __LINE__))
#else
#define VARMESH_ASSERT(cond) static_cast<void>(0)
#endif
