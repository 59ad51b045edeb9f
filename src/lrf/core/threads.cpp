#include "lrf/core/threads.h"

#include <omp.h>

#include <thread>

#include <ATen/Parallel.h>
#include <opencv2/core.hpp>

namespace lrf {
namespace {
int g_threads = 1;
}

void set_thread_count(int n) {
  if (n <= 0) n = static_cast<int>(std::thread::hardware_concurrency());
  if (n <= 0) n = 1;
  g_threads = n;
  at::set_num_threads(n);
  omp_set_num_threads(n);
  cv::setNumThreads(n);
}

int thread_count() { return g_threads; }

void apply_thread_count_to_this_thread() {
  if (omp_get_max_threads() != g_threads) omp_set_num_threads(g_threads);
}

}  // namespace lrf
