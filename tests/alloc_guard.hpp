#pragma once
// Include from exactly ONE translation unit of a test executable: it replaces the global operator new and
// delete for the whole program.
#include <atomic>
#include <cstddef>
#include <cstdlib>
#include <new>

// Allocation guard: while armed, any single allocation above the limit fails with bad_alloc (and is
// remembered), so "never allocate from an absurd count" is checked as a property instead of showing up as
// an out-of-memory kill or a multi-gigabyte memset. Unarmed, these are plain malloc/free.
//
// Countdown: while g_countdown > 0, each allocation counts it down, and the one that brings it to 0 fails
// (then it stays 0: one failure per setting), so a test can fail the 1st, 2nd, ... allocation of an
// operation in turn.
namespace {
std::atomic<bool> g_guard_armed{false};
std::atomic<std::size_t> g_guard_peak{0};
std::atomic<long> g_countdown{0};
constexpr std::size_t kGuardLimit = std::size_t{1} << 20;

void* guarded_alloc(std::size_t n) noexcept {
  if (const long c = g_countdown.load(std::memory_order_relaxed); c > 0) {
    g_countdown.store(c - 1, std::memory_order_relaxed);
    if (c == 1) return nullptr;
  }
  if (g_guard_armed.load(std::memory_order_relaxed)) {
    std::size_t peak = g_guard_peak.load(std::memory_order_relaxed);
    while (n > peak && !g_guard_peak.compare_exchange_weak(peak, n)) {
    }
    if (n > kGuardLimit) return nullptr;
  }
  return std::malloc(n == 0 ? 1 : n);
}
}  // namespace

// GCC sees the std::free of a pointer that came from operator new once these are inlined into the standard
// allocators; that pairing is exactly what a replacement does, so the diagnostic does not apply here.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#endif
void* operator new(std::size_t n) {
  if (void* p = guarded_alloc(n)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) {
  if (void* p = guarded_alloc(n)) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t n, const std::nothrow_t&) noexcept { return guarded_alloc(n); }
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept { return guarded_alloc(n); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

