#pragma once
// Memory for big arrays that are written once soon after they are allocated: blocks of 2 MiB and more are
// fresh anonymous mappings that ask for transparent huge pages before their first touch (Linux, THP in
// "madvise" mode). First writes then cost one page fault per 2 MiB instead of one per 4 KiB, and the
// arrays' address translations fit in the TLB. Fresh mappings matter: heap memory recycled from earlier
// buffers keeps its 4 KiB pages. Smaller blocks, and other systems, use operator new.

#include <cstddef>
#include <vector>

namespace varmesh {

/// `bytes` of memory aligned for any scalar type (2 MiB aligned when huge pages are asked for).
void* huge_allocate(std::size_t bytes);
/// Frees a block of huge_allocate(bytes) given the same size.
void huge_deallocate(void* p, std::size_t bytes) noexcept;

template <class T>
struct HugePageAllocator {
  using value_type = T;
  HugePageAllocator() noexcept = default;
  template <class U> HugePageAllocator(const HugePageAllocator<U>&) noexcept {}
  T* allocate(std::size_t n) { return static_cast<T*>(huge_allocate(n * sizeof(T))); }
  void deallocate(T* p, std::size_t n) noexcept { huge_deallocate(p, n * sizeof(T)); }
  template <class U> bool operator==(const HugePageAllocator<U>&) const noexcept { return true; }
};

/// Physical memory of this machine in bytes, or 0 when unknown. For refusing, before allocating, work that
/// could not fit (the alternative is a bare bad_alloc or the kernel's out-of-memory killer half-way).
double physical_memory_bytes() noexcept;

template <class T> using HugeVector = std::vector<T, HugePageAllocator<T>>;

}  // namespace varmesh
