#include "panoscan/core/allocator.h"

#include <cstdlib>  // defines __GLIBC__ on glibc (through <features.h>)

#include <cstdint>

#if defined(__GLIBC__)
#include <malloc.h>
#endif
#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace panoscan {

bool keep_freed_memory_for_reuse() {
#if defined(__GLIBC__)
  // 32 MB is glibc's largest mmap threshold on 64-bit (DEFAULT_MMAP_THRESHOLD_MAX); setting it also
  // switches off glibc's dynamic threshold, which only rose after the first large block was freed.
  constexpr int kMmapThreshold = 32 << 20;
  // The free memory a heap may keep at its top before it is trimmed: a frame's blocks and more.
  constexpr int kTrimThreshold = 16 << 20;
  const bool mmap_ok = mallopt(M_MMAP_THRESHOLD, kMmapThreshold) == 1;
  const bool trim_ok = mallopt(M_TRIM_THRESHOLD, kTrimThreshold) == 1;
  return mmap_ok && trim_ok;
#else
  return false;
#endif
}

bool advise_huge_pages(void* data, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr std::uintptr_t kHugePage = std::uintptr_t(2) << 20;
  if (data == nullptr || bytes < (std::size_t(8) << 20)) return false;
  const std::uintptr_t begin = (reinterpret_cast<std::uintptr_t>(data) + kHugePage - 1) & ~(kHugePage - 1);
  const std::uintptr_t end = (reinterpret_cast<std::uintptr_t>(data) + bytes) & ~(kHugePage - 1);
  if (end <= begin) return false;
  // Advice only: where the kernel has no huge pages (or THP is off) the pages stay 4 KB.
  return madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE) == 0;
#else
  (void)data;
  (void)bytes;
  return false;
#endif
}

}  // namespace panoscan
