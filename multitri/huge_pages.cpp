#include "multitri/huge_pages.hpp"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <new>

// Sanitizers see through operator new only: under ASan (gcc: __SANITIZE_ADDRESS__; clang: __has_feature)
// every block stays on the heap so that out-of-bounds accesses are still caught.
#if defined(__SANITIZE_ADDRESS__)
#define VARMESH_NO_HUGE_PAGES 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define VARMESH_NO_HUGE_PAGES 1
#endif
#endif

#if defined(__linux__)
#include <sys/mman.h>
#endif
#include <unistd.h>

namespace varmesh {

namespace {
// Clang 14 declares the sized operator delete only with -fsized-deallocation; the unsized one frees the
// same block.
void delete_block(void* p, [[maybe_unused]] std::size_t bytes) noexcept {
#if defined(__cpp_sized_deallocation)
  ::operator delete(p, bytes);
#else
  ::operator delete(p);
#endif
}
}  // namespace

#if defined(__linux__) && defined(MADV_HUGEPAGE) && !defined(VARMESH_NO_HUGE_PAGES)
namespace {
constexpr std::size_t kHuge = std::size_t{2} << 20;
}

void* huge_allocate(std::size_t bytes) {
  if (bytes >= kHuge) {
    // Map 2 MiB more and trim, so that the block starts on a huge-page boundary; munmap(p, bytes) frees it.
    void* m = mmap(nullptr, bytes + kHuge, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (m == MAP_FAILED) throw std::bad_alloc();
    const auto at = reinterpret_cast<std::uintptr_t>(m);
    const std::uintptr_t start = (at + kHuge - 1) & ~(std::uintptr_t{kHuge} - 1);
    const std::uintptr_t end = start + bytes, map_end = at + bytes + kHuge;
    const std::uintptr_t page_end = (end + 4095) & ~std::uintptr_t{4095};
    if (start > at) munmap(m, start - at);
    if (map_end > page_end) munmap(reinterpret_cast<void*>(page_end), map_end - page_end);
    madvise(reinterpret_cast<void*>(start), bytes, MADV_HUGEPAGE);
    return reinterpret_cast<void*>(start);
  }
  return ::operator new(bytes);
}

void huge_deallocate(void* p, std::size_t bytes) noexcept {
  if (bytes >= kHuge) {
    munmap(p, bytes);
    return;
  }
  delete_block(p, bytes);
}
#else
void* huge_allocate(std::size_t bytes) { return ::operator new(bytes); }
void huge_deallocate(void* p, std::size_t bytes) noexcept { delete_block(p, bytes); }
#endif

double physical_memory_bytes() noexcept {
  double bytes = 0.0;
#if defined(_SC_PHYS_PAGES) && defined(_SC_PAGESIZE)
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
  if (pages > 0 && page > 0) bytes = double(pages) * double(page);
#endif
#if defined(__linux__)
  // A container's memory limit (cgroup v2, then v1) is what the out-of-memory killer enforces; sysconf does
  // not see it. "max" (v2) or a huge number (v1) means no limit.
  for (const char* path : {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"}) {
    std::FILE* f = std::fopen(path, "r");
    if (!f) continue;
    char text[64] = {};
    const bool read = std::fgets(text, sizeof text, f) != nullptr;
    std::fclose(f);
    char* end = nullptr;
    const double limit = read ? std::strtod(text, &end) : 0.0;
    if (read && end != text && limit > 0.0 && limit < 1e18 && (bytes == 0.0 || limit < bytes)) bytes = limit;
    break;
  }
#endif
  return bytes;
}

}  // namespace varmesh
