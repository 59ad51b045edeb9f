#include "lrf/core/expected_time.h"

#include <cmath>
#include <cstdio>

#include "lrf/core/log.h"
#include "lrf/core/progress.h"

namespace lrf {

const char* const kGaussianRunNote =
    "training only; steps often slow down while densification grows the field, and scoring adds its own time";

std::string expected_time_line(int64_t steps, int64_t measured_steps, double measured_seconds,
                               const std::string& note, double prepared_seconds) {
  const double per_step = measured_steps > 0 ? measured_seconds / double(measured_steps) : std::nan("");
  char pace[32];
  if (per_step >= 1)
    std::snprintf(pace, sizeof pace, "%.1f s/step", per_step);
  else
    std::snprintf(pace, sizeof pace, "%.0f ms/step", 1000 * per_step);
  const double training = measured_seconds * double(steps) / double(measured_steps);
  std::string line = "expected: " + std::to_string(steps) + " steps at " + pace + " \u2248 " +
                     Progress::format_duration(training);
  if (prepared_seconds >= 1)
    line += ", " + Progress::format_duration(prepared_seconds + training) + " in all with the " +
            Progress::format_duration(prepared_seconds) + " spent before the first step";
  line += std::string(" (an estimate from the first ") +
                     std::to_string(measured_steps) + " steps";
  return line + (note.empty() ? ")" : "; " + note + ")");
}

ExpectedTimeNotice::ExpectedTimeNotice(int64_t steps, std::string note, double prepared_seconds, int64_t after_steps,
                                       double after_seconds)
    : steps_(steps),
      after_steps_(after_steps),
      after_seconds_(after_seconds),
      prepared_seconds_(prepared_seconds),
      note_(std::move(note)) {}

void ExpectedTimeNotice::observe(int64_t steps_done, double seconds) {
  if (said_ || steps_done >= steps_ || steps_done <= 0) return;
  if (steps_done < after_steps_ && seconds < after_seconds_) return;
  said_ = true;
  log_info(expected_time_line(steps_, steps_done, seconds, note_, prepared_seconds_));
}

}  // namespace lrf
