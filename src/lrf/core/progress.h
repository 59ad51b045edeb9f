#pragma once
// Progress of a long job: step / total, named metrics (loss, PSNR, ...), steps per second and time left.
// Prints at most every `interval_seconds` (and at the last step); quiet mode prints nothing, JSON mode
// prints one JSON object per line.
#include <chrono>
#include <string>
#include <utility>
#include <vector>

namespace lrf {

class Progress {
 public:
  Progress(std::string task, long total_steps, double interval_seconds = 2.0, long first_step = 0);
  // Reports that `step` steps are done (1-based count), with the current metrics.
  void update(long step, const std::vector<std::pair<std::string, double>>& metrics = {});
  void finish(const std::vector<std::pair<std::string, double>>& metrics = {});
  double elapsed_seconds() const;
  // Leaves out of the elapsed time, rate and time left `seconds` just spent on something else (scoring a
  // field at a checkpoint, say).
  void exclude(double seconds);
  // Steps per second measured since construction (excluding steps done before a resume).
  double rate() const;
  double eta_seconds(long step) const;
  // Formats seconds as "1h02m", "3m05s" or "12.3s".
  static std::string format_duration(double seconds);

 private:
  void print(long step, const std::vector<std::pair<std::string, double>>& metrics, bool final);
  std::string task_;
  long total_;
  long first_step_;
  long last_step_ = 0;
  double interval_;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_print_;
};

}  // namespace lrf
