#include "lrf/finetune/finetune_loop.h"

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <optional>
#include <string>

#include <torch/torch.h>

#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/progress.h"
#include "lrf/core/run_loop.h"
#include "lrf/core/stop_request.h"
#include "lrf/distributed/gradient_averager.h"
#include "lrf/finetune/finetune_output.h"

namespace lrf {

BatchShare batch_share(int64_t total, int rank, int world) {
  BatchShare s;
  s.total = total;
  s.world = world;
  s.first = total * rank / world;
  s.count = total * (rank + 1) / world - s.first;
  return s;
}

double share_weight(const BatchShare& share) {
  if (share.count == share.total && share.world == 1) return 1.0;
  return static_cast<double>(share.world) * static_cast<double>(share.count) / static_cast<double>(share.total);
}

namespace {

constexpr const char* kSecondsKey = "lrf_seconds";  // checkpoint metadata: wall time of the steps so far

// Restores the checkpoint on rank 0 and copies the state to every rank. A refusal on rank 0 (other
// options, a damaged file) stops every rank with rank 0's message. Returns the checkpoint's recorded
// wall time on rank 0 (0 for checkpoints written before it was recorded), 0 elsewhere.
double start_state(const FinetuneLoop& l) {
  DataParallelGroup& g = *l.group;
  std::string refusal;
  double seconds_before = 0;
  if (l.resume && g.is_main()) {
    try {
      auto meta = l.adam->load(l.checkpoint);
      if (meta["lrf_resume_key"] != l.resume_key) {
        fail(l.checkpoint, "was written with different options; resume with the same " + l.resume_hint +
                               " (checkpoint: " + meta["lrf_resume_key"] + ")");
      }
      warn_if_precision_changed(meta, l.precision, l.checkpoint);
      if (auto it = meta.find(kSecondsKey); it != meta.end()) {
        char* end = nullptr;
        const double recorded = std::strtod(it->second.c_str(), &end);
        if (end != it->second.c_str() && std::isfinite(recorded) && recorded >= 0) seconds_before = recorded;
      }
    } catch (const Error& e) {
      if (!g.distributed()) throw;
      refusal = e.what();
    }
  }
  if (!g.distributed()) return seconds_before;
  refusal = g.from_main("start", refusal);
  if (!refusal.empty()) fail(g.prefix() + "rank 0 cannot start: " + refusal);
  std::vector<double> step = {g.is_main() ? static_cast<double>(l.adam->steps()) : 0.0};
  g.sum(step);
  l.adam->set_steps(static_cast<int64_t>(step[0]));
  g.broadcast_from_main(l.adam->state_tensors());
  return seconds_before;
}

}  // namespace

FinetuneLoopResult run_finetune_loop(const FinetuneLoop& l) {
  DataParallelGroup& g = *l.group;
  ParamAdam& adam = *l.adam;
  const double seconds_before = start_state(l);
  const int64_t start = adam.steps();
  if (l.resume) log_info(g.prefix() + "resuming from " + l.checkpoint + " at step " + std::to_string(start));
  GradientAverager averager(g, adam.parameters());
  if (g.distributed()) {
    log_info(g.prefix() + "gradients averaged over " + std::to_string(g.world_size()) + " ranks in " +
             std::to_string(averager.buckets()) + " bucket(s)");
  }

  const auto t0 = std::chrono::steady_clock::now();
  auto seconds_so_far = [&] {
    return seconds_before + std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  int64_t checkpointed = l.resume ? start : -1;
  auto save_checkpoint = [&] {
    if (g.is_main()) {
      adam.save(l.checkpoint, {{"lrf_kind", l.kind},
                               {"lrf_resume_key", l.resume_key},
                               precision_metadata(l.precision),
                               {kSecondsKey, std::to_string(seconds_so_far())}});
    }
    checkpointed = adam.steps();
  };
  auto advice = [&] {
    if (checkpointed < 0) return std::string("; no checkpoint was written yet");
    return "; the last complete checkpoint is " + l.checkpoint + " (step " + std::to_string(checkpointed) +
           "): continue with --resume";
  };

  FinetuneLoopResult result;
  result.first_step = start;
  std::optional<Progress> progress;
  if (g.is_main()) progress.emplace(l.task, l.steps, 2.0, start);
  bool stop = false;
  RunLoop loop;
  loop.total_steps = l.steps;
  loop.first_step = start;
  loop.checkpoint_every = l.checkpoint_every;
  loop.checkpoint = l.checkpoint;
  loop.progress = progress ? &*progress : nullptr;
  loop.save = save_checkpoint;
  // A stop request travels with the step's losses, so that every rank of a data-parallel group stops after
  // the same step.
  loop.stop_requested = [&] { return stop; };
  loop.step = [&] {
    const int64_t step = adam.steps();  // done before this one
    adam.zero_grad();
    FinetuneStepLoss part;
    std::vector<double> values;
    try {
      part = l.step_loss(step);
      values.push_back(part.loss.item<double>());
      for (const auto& [name, value] : part.metrics) values.push_back(value);
      values.push_back(stop_signal() ? 1.0 : 0.0);
      const auto s0 = std::chrono::steady_clock::now();
      g.sum(values);
      stop = values.back() > 0;
      values.pop_back();
      result.sync_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - s0).count();
    } catch (const std::exception& e) {
      if (!g.distributed()) throw;
      g.fail_step("step " + std::to_string(step + 1), e.what(), advice());
    }
    for (double& v : values) v /= g.world_size();
    // Every rank sees the same global loss, so every rank stops here together.
    if (!std::isfinite(values[0])) fail_non_finite_loss(l.out, values[0], step + 1, l.checkpoint);
    try {
      averager.begin_step();
      part.loss.backward();
      const auto s0 = std::chrono::steady_clock::now();
      averager.finish_step();
      result.sync_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - s0).count();
    } catch (const std::exception& e) {
      if (!g.distributed()) throw;
      g.fail_step("step " + std::to_string(step + 1) + " (backward and gradient all-reduce)", e.what(), advice());
    }
    adam.step();
    result.last_loss = values[0];
    LoopStep shown{adam.steps(), {{"loss", values[0]}}};
    for (size_t k = 0; k < part.metrics.size(); ++k) {
      result.last_metrics[part.metrics[k].first] = values[k + 1];
      shown.shown.emplace_back(part.metrics[k].first, values[k + 1]);
    }
    return shown;
  };
  run_loop(loop);
  if (progress) progress->finish();
  result.steps = l.steps;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  result.total_seconds = seconds_so_far();
  return result;
}

void finish_together(DataParallelGroup& group, const std::string& out) {
  if (!group.distributed()) return;
  try {
    group.barrier();
  } catch (const std::exception& e) {
    group.fail_step("after the last step, waiting for rank 0 to write " + out, e.what(), "");
  }
}

}  // namespace lrf
