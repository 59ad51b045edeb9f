#include "lrf/core/allocator.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace lrf {

void keep_freed_memory() {
#if defined(__GLIBC__)
  // Every block comes from the heap, never from its own mmap...
  mallopt(M_MMAP_MAX, 0);
  // ...and the heap is not trimmed back while less than 1 GiB of it is free.
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
#endif
}

}  // namespace lrf
