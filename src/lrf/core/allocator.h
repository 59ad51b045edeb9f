#pragma once
namespace lrf {
// Tells glibc's allocator to keep freed memory for reuse instead of handing it back to the kernel. Training
// frees and reallocates the same tens of MB of tensors every step; by default large blocks are unmapped on
// free, and touching them again costs a page fault per 4 KiB (at 63x47 px with 50k Gaussians, about a
// quarter of all CPU time). Call once at start-up, before any thread starts.
void keep_freed_memory();
}  // namespace lrf
