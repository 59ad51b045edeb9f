#pragma once
// The resumable fine-tuning loop that Stage I and Stage III share: for each step from the checkpoint's
// (or 0) to `steps`, the stage's loss on this rank's share of the step's global batch, one stop on a
// non-finite loss, the backward with the gradients averaged over the ranks, one Adam step (the same on
// every rank, so the ranks' weights stay equal), progress, and a checkpoint every `checkpoint_every`
// steps and at the end, written by rank 0 alone. A job of one process is the same loop without
// communication.
//
// What makes a split batch the same optimisation as the whole: a stage's loss is a mean over the
// global batch, and each rank returns its share's part of it scaled so that the mean over the ranks is
// the global loss (share_weight below); averaging the gradients then gives the global batch's gradient.
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <ATen/Tensor.h>

#include "lrf/core/precision.h"
#include "lrf/core/run_control.h"
#include "lrf/distributed/data_parallel_group.h"
#include "lrf/optim/param_adam.h"

namespace lrf {

// The part of a global batch of `total` samples that `rank` of `world` takes: [first, first + count).
struct BatchShare {
  int64_t first = 0, count = 0, total = 0;
  int world = 1;
};
BatchShare batch_share(int64_t total, int rank, int world);
// The factor that turns the mean over a share's samples into its part of the global mean, such that the
// mean of the ranks' parts is the global mean: world x count / total (exactly 1 for one process).
double share_weight(const BatchShare& share);

struct FinetuneStepLoss {
  at::Tensor loss;                                        // scalar carrying the gradient (this rank's part)
  std::vector<std::pair<std::string, double>> metrics;    // this rank's parts of the reported terms
};

// Made from the fine-tuning's options' RunControl: out (the output file, named in errors), resume and
// checkpoint_every.
struct FinetuneLoop : RunControl {
  explicit FinetuneLoop(const RunControl& control) : RunControl(control) {}
  std::string task;         // "finetune-encoder": progress and messages
  std::string checkpoint;   // the checkpoint file
  std::string kind;         // recorded in the checkpoint ("finetune-encoder")
  std::string resume_key;   // options that must match to resume (JSON text)
  std::string resume_hint;  // what "same options" means, for the refusal
  int64_t steps = 0;
  Precision precision = Precision::fp32;
  ParamAdam* adam = nullptr;
  DataParallelGroup* group = nullptr;
  std::function<FinetuneStepLoss(int64_t step)> step_loss;
};

struct FinetuneLoopResult {
  int64_t first_step = 0, steps = 0;
  double seconds = 0, last_loss = 0;  // seconds: this call's
  // Wall time of every step so far, over all the sessions that made them: each checkpoint records the
  // time up to it, so a resumed run adds its own to what the checkpoint had (the time between the last
  // checkpoint and an interruption is not counted; those steps are made again).
  double total_seconds = 0;
  // Time this rank waited on the other ranks: the all-reduce of the loss terms and what was left of the
  // gradient all-reduce when the backward ended (the rest overlapped with it). 0 for one process.
  double sync_seconds = 0;
  std::map<std::string, double> last_metrics;  // global values (means over the ranks' parts)
};

// Runs the loop (resuming if asked: rank 0 reads the checkpoint and every rank starts from its state).
// Throws lrf::Error on a non-finite loss, a checkpoint written with other options, or a failed rank
// (naming it, and the last complete checkpoint).
FinetuneLoopResult run_finetune_loop(const FinetuneLoop& loop);

// After rank 0 wrote `out`: every rank waits for the others, so that no rank reports success when rank 0
// failed to write the result.
void finish_together(DataParallelGroup& group, const std::string& out);

}  // namespace lrf
