#include "lrf/core/training_steps.h"

#include "lrf/core/error.h"

namespace lrf {

void check_training_steps(int64_t steps, const std::string& option) {
  if (steps < 1) fail_usage(option + " must be at least 1");
  if (steps > kMaxTrainingSteps)
    fail_usage(option + " must be at most " + std::to_string(kMaxTrainingSteps) + ", got " + std::to_string(steps));
}

}  // namespace lrf
