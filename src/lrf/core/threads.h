#pragma once
namespace lrf {
// Sets the thread count of libtorch (intra-op), OpenMP and OpenCV once at start-up; n <= 0 means all cores.
void set_thread_count(int n);
int thread_count();
// Applies that count to the calling thread too: OpenMP keeps its setting per thread, so a thread that a
// library started (the viewer's HTTP workers) would otherwise run parallel regions on every core.
void apply_thread_count_to_this_thread();
}  // namespace lrf
