#pragma once
// Measurements for efficiency tables (the paper's Table 5): wall time, peak memory, storage on disk.
#include <chrono>
#include <string>

namespace lrf {

// Peak resident memory of this process in MiB (VmHWM from /proc/self/status); 0 when unavailable.
double peak_memory_mb();
// Current resident memory of this process in MiB (VmRSS); 0 when unavailable.
double current_memory_mb();
// Resets the peak that peak_memory_mb() reports to the current resident size, so that one process can
// measure the peak of each of several jobs in turn (lrf compare trains several methods). Uses Linux's
// /proc/self/clear_refs; returns false if the kernel refuses.
bool reset_peak_memory();

// Total size in MiB (2^20 bytes) of the regular files under `path` (recursively), or of `path` itself if it
// is a file. Symbolic links are not followed, so nothing is counted twice. Throws lrf::Error if missing.
double directory_size_mb(const std::string& path);

// Wall-clock time on a monotonic clock, started at construction.
class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  void reset() { start_ = std::chrono::steady_clock::now(); }
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  std::chrono::steady_clock::time_point start_;
};

}  // namespace lrf
