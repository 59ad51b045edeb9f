#pragma once
// The range every step count a user gives (--steps and its kin) must lie in. 1e8 steps is weeks of
// training at any speed lrf reaches; a larger count is a typo, and one past 2^63 used to be read as the
// largest integer and shown as an estimate of "-2147483648h".
#include <cstdint>
#include <string>

namespace lrf {

constexpr int64_t kMaxTrainingSteps = 100'000'000;

// Throws a usage error naming `option` unless 1 <= steps <= kMaxTrainingSteps.
void check_training_steps(int64_t steps, const std::string& option = "--steps");

}  // namespace lrf
