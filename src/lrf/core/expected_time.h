#pragma once
// How long a training run should take, said once its first steps have been timed: before then a CPU run
// gives no hint whether it needs minutes or hours. It is an extrapolation of those steps' pace, and says so.
#include <cstdint>
#include <string>

namespace lrf {

// "expected: 30000 steps at 41 ms/step ≈ 20m30s (from the first 20 steps; NOTE)": `steps` at the pace of
// the `measured_steps` that took `measured_seconds`. `prepared_seconds` is what the job spent before its first
// step (loading, triangulating points, encoding views); from a second on, the line adds the whole job's time,
// so that a forecast of the steps alone does not hide minutes already gone.
std::string expected_time_line(int64_t steps, int64_t measured_steps, double measured_seconds, const std::string& note,
                               double prepared_seconds = 0);

// Prints expected_time_line once, as soon as `after_steps` steps or `after_seconds` have passed, whichever
// comes first (and not for a run that ends before then, which needs no forecast).
class ExpectedTimeNotice {
 public:
  // `steps` is what this session will make (the total less the steps a resumed run had done).
  ExpectedTimeNotice(int64_t steps, std::string note, double prepared_seconds = 0, int64_t after_steps = 20,
                     double after_seconds = 5);
  // After each step: `steps_done` this session, in `seconds` of training time.
  void observe(int64_t steps_done, double seconds);

 private:
  int64_t steps_, after_steps_;
  double after_seconds_, prepared_seconds_;
  std::string note_;
  bool said_ = false;
};

// The note for a Gaussian field's run: the first steps are the cheapest while densification grows the field.
extern const char* const kGaussianRunNote;

}  // namespace lrf
