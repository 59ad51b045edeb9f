#pragma once
namespace lrf {
// Sets the thread count of libtorch (intra-op), OpenMP and OpenCV once at start-up; n <= 0 means all cores.
void set_thread_count(int n);
int thread_count();
}  // namespace lrf
