#pragma once
// A training run on disk, shared by every kind of field (RGB now, latents in Stage II): the output
// folder rules, periodic atomic checkpoints, the CSV log, progress, divergence handling and the final
// point_cloud.ply.
//
// Folder layout: OUT/config.json (written by the caller), OUT/checkpoint.pt, OUT/train_log.csv,
// OUT/point_cloud.ply (refreshed at every checkpoint; config.json gains a "result" when the run ends).
#include <cstdint>
#include <functional>
#include <string>

#include "lrf/core/run_control.h"
#include "lrf/splat/run/output_folder.h"
#include "lrf/splat/train/trainer.h"

namespace lrf::splat {

// Refuses an existing non-empty OUT unless force or resume, or unless it holds only a run that stopped before
// its first checkpoint (which is started afresh); creates OUT otherwise. With force (and no resume) a stale
// checkpoint is removed so that the run starts afresh. Returns the claimed folder (output_folder.h): hold it
// for as long as the job writes OUT; a second job on OUT is refused, and a job that fails before its first
// checkpoint removes the OUT it created.
[[nodiscard]] OutputFolder prepare_output_dir(const std::string& out, bool force, bool resume);

// Whether OUT holds what a run leaves when it is killed (or fails in a folder it did not create) before its
// first checkpoint: its config.json without a "result", and no checkpoint or field. A rerun takes it over.
bool stopped_before_first_checkpoint(const std::string& out);
// Throws lrf::Error naming `checkpoint`: --resume found none in OUT (saying how to start again when the
// run stopped before its first one).
[[noreturn]] void fail_no_checkpoint(const std::string& checkpoint, const std::string& out);

std::string checkpoint_path(const std::string& out);

// Whether OUT holds a run that trained to its end: config.json has its "result" and point_cloud.ply
// exists. point_cloud.ply alone does not say so: every checkpoint refreshes it (see above).
bool run_finished(const std::string& out);

// Made from the job's options' RunControl (out, resume, checkpoint_every; force is the job's own business,
// done by prepare_output_dir before the run).
struct RunOptions : RunControl {
  explicit RunOptions(const RunControl& control = {}) : RunControl(control) {}
  int64_t log_every = 10;  // rows of train_log.csv (mean loss over the rows' steps)
  std::string task = "train";
  // Seconds the job spent before its first step (scene, points, encoded views): the forecast counts them.
  double prepared_seconds = 0;
  // State kept beside the trainer's (e.g. a decoder trained with the field): written with every checkpoint
  // and at the end, read back on resume and when a divergence falls back to the last checkpoint.
  std::function<void()> save_extra, load_extra;
  // What point_cloud.ply holds of the trained field (e.g. without channels that only guided training);
  // unset: the field as the trainer exports it. Checkpoints keep the whole field either way.
  std::function<Gaussians(Gaussians)> exported;
  // Every score_every steps and at the last one, score(step, elapsed seconds) gives one row of
  // OUT/<score_file> (a CSV whose header, score_header, names the step first), written at once; a resumed
  // run keeps the rows up to its checkpoint. The time spent scoring counts neither in the elapsed time nor in the progress's rate.
  int64_t score_every = 0;
  std::string score_file = "curve.csv", score_header;
  std::function<std::string(int64_t step, double elapsed_seconds)> score;
};

struct RunSummary {
  int64_t steps = 0, gaussians = 0;
  double seconds = 0, last_loss = 0, last_psnr = 0;
};

// Trains to the end (resuming from OUT/checkpoint.pt when asked). On divergence the field of the last
// good checkpoint is written as point_cloud.ply and TrainingDiverged is rethrown.
RunSummary run_training(Trainer& trainer, const RunOptions& options);

}  // namespace lrf::splat
