#include "panoscan/core/allocator.h"

#include <cstdlib>  // defines __GLIBC__ on glibc (through <features.h>)

#if defined(__GLIBC__)
#include <malloc.h>
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

}  // namespace panoscan
