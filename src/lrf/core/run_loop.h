#pragma once
// The loop every resumable training job runs: Gaussian fields (RGB, latent, feature, refinement), latent
// NeRFs, and Stage I / III fine-tuning. One step at a time to the total, progress after each, a checkpoint
// every `checkpoint_every` steps and at the end, and Ctrl-C / SIGTERM turned into a checkpoint at the next
// step boundary followed by Interrupted (the CLI exits with 130 / 143; `--resume` continues). What a step
// and a checkpoint are is the job's; the rules about when they happen are kept here, once.
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace lrf {

class Progress;

// What one step reports to the loop.
struct LoopStep {
  int64_t steps_done = 0;                              // after this step (1-based count)
  std::vector<std::pair<std::string, double>> shown;   // values the progress line shows (loss, PSNR, ...)
};

struct RunLoop {
  int64_t total_steps = 0;
  int64_t first_step = 0;        // steps done before this session (a resumed run's checkpoint)
  int64_t checkpoint_every = 0;  // 0: only at the end (and on a stop request)
  std::string checkpoint;        // the file that save() writes, named when a stop request ends the run
  // Progress of this job (steps counted from first_step); null: none shown (a data-parallel group's other ranks).
  Progress* progress = nullptr;
  // Said once the first steps are timed (expected_time.h); empty: no forecast.
  std::string expected_time_note;
  // Seconds the job spent before this loop (loading, points, encoding), added to the forecast's total.
  double prepared_seconds = 0;
  std::function<LoopStep()> step;
  std::function<void()> save;
  // Whether to stop after the step just made; unset: a Ctrl-C or SIGTERM arrived (stop_signal()). A
  // data-parallel job answers with what every rank agreed on, so that all stop after the same step.
  std::function<bool()> stop_requested;
};

// Runs steps until total_steps are done, then saves once more. Throws Interrupted (stop_request.h) after a
// checkpoint when a stop is requested before the last step; whatever step() or save() throws passes through
// (the job decides what a divergence leaves behind). Returns the steps done.
int64_t run_loop(const RunLoop& loop);

}  // namespace lrf
