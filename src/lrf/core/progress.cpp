#include "lrf/core/progress.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include <nlohmann/json.hpp>

#include "lrf/core/log.h"

namespace lrf {

Progress::Progress(std::string task, long total_steps, double interval_seconds, long first_step)
    : task_(std::move(task)),
      total_(total_steps),
      first_step_(first_step),
      last_step_(first_step),
      interval_(interval_seconds),
      start_(std::chrono::steady_clock::now()),
      last_print_(start_) {}

double Progress::elapsed_seconds() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void Progress::exclude(double seconds) {
  const auto d = std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(seconds));
  start_ += d;
  last_print_ += d;
}

double Progress::rate() const {
  double t = elapsed_seconds();
  long done = last_step_ - first_step_;
  return t > 0 && done > 0 ? done / t : 0.0;
}

double Progress::eta_seconds(long step) const {
  double r = rate();
  return r > 0 ? (total_ - step) / r : 0.0;
}

std::string Progress::format_duration(double seconds) {
  char buf[64];
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  // Days past two of them: an hour count of a long estimate used to overflow an int ("-2147483648h").
  if (seconds >= 1e9) return "more than 30 years";
  if (seconds >= 48 * 3600) {
    std::snprintf(buf, sizeof buf, "%lldd%02dh", static_cast<long long>(seconds / 86400),
                  static_cast<int>(std::fmod(seconds, 86400) / 3600));
  } else if (seconds >= 3600) {
    std::snprintf(buf, sizeof buf, "%dh%02dm", int(seconds / 3600), int(std::fmod(seconds, 3600) / 60));
  } else if (seconds >= 60) {
    std::snprintf(buf, sizeof buf, "%dm%02ds", int(seconds / 60), int(std::fmod(seconds, 60)));
  } else {
    std::snprintf(buf, sizeof buf, "%.1fs", seconds);
  }
  return buf;
}

void Progress::update(long step, const std::vector<std::pair<std::string, double>>& metrics) {
  last_step_ = step;
  auto now = std::chrono::steady_clock::now();
  bool due = std::chrono::duration<double>(now - last_print_).count() >= interval_;
  if (due || step >= total_) {
    last_print_ = now;
    print(step, metrics, false);
  }
}

void Progress::finish(const std::vector<std::pair<std::string, double>>& metrics) {
  print(last_step_, metrics, true);
}

void Progress::print(long step, const std::vector<std::pair<std::string, double>>& metrics, bool final) {
  if (log_mode() == LogMode::quiet) return;
  if (log_mode() == LogMode::json) {
    nlohmann::json line = {{"task", task_}, {"step", step}, {"total", total_},
                           {"rate", rate()}, {"elapsed", elapsed_seconds()},
                           {"eta", eta_seconds(step)}, {"done", final}};
    for (const auto& [k, v] : metrics) line[k] = v;
    std::fprintf(stderr, "%s\n", line.dump().c_str());
    std::fflush(stderr);
    return;
  }
  std::ostringstream s;
  s << task_ << " " << step << "/" << total_;
  if (total_ > 0) s << " (" << int(100.0 * step / total_) << "%)";
  for (const auto& [k, v] : metrics) s << "  " << k << " " << v;
  char rate_buf[32];
  std::snprintf(rate_buf, sizeof rate_buf, "%.2f", rate());
  s << "  " << rate_buf << " it/s";
  if (final) {
    s << "  done in " << format_duration(elapsed_seconds());
  } else {
    s << "  elapsed " << format_duration(elapsed_seconds()) << "  left " << format_duration(eta_seconds(step));
  }
  std::fprintf(stderr, "%s\n", s.str().c_str());
  std::fflush(stderr);
}

}  // namespace lrf
