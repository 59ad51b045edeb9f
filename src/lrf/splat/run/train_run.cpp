#include "lrf/splat/run/train_run.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <sstream>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/core/expected_time.h"
#include "lrf/core/log.h"
#include "lrf/core/progress.h"
#include "lrf/core/run_info.h"
#include "lrf/core/run_loop.h"
#include "lrf/core/train_log.h"
#include "lrf/splat/ply_io.h"

namespace fs = std::filesystem;

namespace lrf::splat {
namespace {

constexpr const char* kLogHeader =
    "step,loss,psnr,gaussians,elapsed_s,render_ms,loss_ms,backward_ms,adam_ms,densify_ms,loss_backward_ms,"
    "extra_adam_ms";
constexpr int kElapsedColumn = 4;

}  // namespace

std::string checkpoint_path(const std::string& out) { return (fs::path(out) / "checkpoint.pt").string(); }

bool run_finished(const std::string& out) {
  const fs::path config = fs::path(out) / "config.json";
  if (!fs::exists(config) || !fs::exists(fs::path(out) / "point_cloud.ply")) return false;
  return read_json_file(config.string()).contains("result");
}

bool stopped_before_first_checkpoint(const std::string& out) {
  const fs::path config = fs::path(out) / "config.json";
  std::error_code ec;
  if (!fs::exists(config, ec) || holds_checkpoint(out)) return false;
  for (const char* field : {"point_cloud.ply", "field.safetensors"})
    if (fs::exists(fs::path(out) / field, ec)) return false;
  try {
    const nlohmann::json j = read_json_file(config.string());
    return j.is_object() && j.contains("command") && j.contains("versions") && !j.contains("result");  // run_record's
  } catch (const Error&) {
    return false;
  }
}

void fail_no_checkpoint(const std::string& checkpoint, const std::string& out) {
  fail(checkpoint, "--resume: no checkpoint to resume from" +
                       std::string(stopped_before_first_checkpoint(out)
                                       ? "; the run stopped before its first checkpoint: run the same command "
                                         "without --resume to start it again"
                                       : ""));
}

OutputFolder prepare_output_dir(const std::string& out, bool force, bool resume) {
  std::error_code ec;
  if (fs::exists(out) && !fs::is_directory(out)) fail(out, "exists and is not a folder");
  if (resume && !fs::exists(checkpoint_path(out))) fail_no_checkpoint(checkpoint_path(out), out);
  std::vector<std::string> created = missing_folders(out);
  fs::create_directories(out, ec);
  if (ec) fail(out, "cannot create folder: " + ec.message());
  // Locked before anything in it is looked at or removed: a job still writing it makes this one stop here.
  // Claimed at once, so that a failure below removes what this job created.
  OutputFolder claimed(FolderLock(out), out, std::move(created));
  remove_stale_temporaries(out);
  bool non_empty = false;
  for (const auto& e : fs::directory_iterator(out)) non_empty = non_empty || e.path().filename() != ".lock";
  if (non_empty && !force && !resume) {
    if (!stopped_before_first_checkpoint(out))
      fail(out, "output folder exists; pass --resume to continue its run or --force to overwrite it");
    log_info(out + " holds a run that stopped before its first checkpoint: starting it again");
  }
  if (resume && !fs::exists(checkpoint_path(out))) fail_no_checkpoint(checkpoint_path(out), out);
  if (force && !resume) fs::remove(checkpoint_path(out), ec);
  return claimed;
}

RunSummary run_training(Trainer& trainer, const RunOptions& o) {
  const std::string ckpt = checkpoint_path(o.out);
  const std::string ply_path = (fs::path(o.out) / "point_cloud.ply").string();
  auto write_field = [&] {
    Gaussians field = trainer.export_gaussians();
    write_ply(ply_path, o.exported ? o.exported(std::move(field)) : field);
  };
  const bool scoring = o.score_every > 0 && o.score;
  TrainLog log((fs::path(o.out) / "train_log.csv").string(), kLogHeader, kElapsedColumn);
  TrainLog scores((fs::path(o.out) / o.score_file).string(), o.score_header);
  double elapsed_before = 0;
  if (o.resume) {
    trainer.load_checkpoint(ckpt);
    if (o.load_extra) o.load_extra();
    elapsed_before = log.resume(trainer.steps_done());
    if (scoring) scores.resume(trainer.steps_done());
    log_info("resuming " + o.out + " at step " + std::to_string(trainer.steps_done()));
  }
  const int64_t total = trainer.options().iterations;
  Progress progress(o.task, total, 2.0, trainer.steps_done());

  RunSummary summary;
  double loss_sum = 0;
  int64_t loss_count = 0;
  StepTimings time_sum;
  double last_psnr = std::nan("");
  RunLoop loop;
  loop.total_steps = total;
  loop.first_step = trainer.steps_done();
  loop.checkpoint_every = o.checkpoint_every;
  loop.checkpoint = ckpt;
  loop.progress = &progress;
  loop.expected_time_note = kGaussianRunNote;
  loop.prepared_seconds = o.prepared_seconds;
  // Each checkpoint also refreshes point_cloud.ply, so that an unfinished run can be rendered and scored.
  // The log goes first: killed before the checkpoint is written, a resumed run drops the log's rows past
  // the previous checkpoint; the other way round, it would lose the rows since that checkpoint.
  loop.save = [&] {
    log.write();
    if (scoring) scores.write();
    trainer.save_checkpoint(ckpt);
    if (o.save_extra) o.save_extra();
    write_field();
  };
  loop.step = [&] {
    auto r = trainer.step();
    loss_sum += r.loss;
    ++loss_count;
    time_sum.render += r.timings.render;
    time_sum.loss += r.timings.loss;
    time_sum.backward += r.timings.backward;
    time_sum.optimizer += r.timings.optimizer;
    time_sum.densify += r.timings.densify;
    time_sum.loss_backward += r.timings.loss_backward;
    time_sum.extra_optimizer += r.timings.extra_optimizer;
    if (!std::isnan(r.psnr)) last_psnr = r.psnr;
    summary.last_loss = r.loss;
    if (r.densified)
      log_info("step " + std::to_string(r.step) + ": densified " + std::to_string(r.densify.before) + " -> " +
               std::to_string(r.densify.after) + " Gaussians (" + std::to_string(r.densify.cloned) + " cloned, " +
               std::to_string(r.densify.split) + " split, " + std::to_string(r.densify.pruned) + " pruned)");
    if (r.step % o.log_every == 0 || trainer.done()) {
      std::ostringstream row;
      row << r.step << "," << std::setprecision(6) << loss_sum / double(loss_count) << "," << std::setprecision(4)
          << last_psnr << "," << r.gaussians << "," << std::setprecision(6)
          << elapsed_before + progress.elapsed_seconds() << std::setprecision(4);
      for (double t : {time_sum.render, time_sum.loss, time_sum.backward, time_sum.optimizer, time_sum.densify,
                       time_sum.loss_backward, time_sum.extra_optimizer})
        row << "," << t / double(loss_count);
      log.add(row.str());
      loss_sum = 0;
      loss_count = 0;
      time_sum = StepTimings();
    }
    if (scoring && (r.step % o.score_every == 0 || trainer.done())) {
      const auto t0 = std::chrono::steady_clock::now();
      scores.add(std::to_string(r.step) + "," + o.score(r.step, elapsed_before + progress.elapsed_seconds()));
      // Written at once, so that a curve can be watched as it grows; a resumed run drops the rows past its
      // checkpoint.
      scores.write();
      progress.exclude(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    return LoopStep{r.step, {{"loss", r.loss}, {"psnr", last_psnr}, {"gaussians", double(r.gaussians)}}};
  };
  try {
    run_loop(loop);
  } catch (const TrainingDiverged& e) {
    log_error(e.what());
    if (fs::exists(ckpt)) {
      trainer.load_checkpoint(ckpt);
      if (o.load_extra) o.load_extra();
      if (o.save_extra) o.save_extra();
      write_field();
      log_error("kept the last good checkpoint (step " + std::to_string(trainer.steps_done()) + ") and wrote " +
                ply_path + " from it");
    } else {
      log_error("no checkpoint was saved before the divergence; nothing written");
    }
    throw;
  }
  write_field();
  progress.finish({{"loss", summary.last_loss}, {"gaussians", double(trainer.gaussians().size())}});
  summary.steps = trainer.steps_done();
  summary.gaussians = trainer.gaussians().size();
  summary.seconds = elapsed_before + progress.elapsed_seconds();
  summary.last_psnr = last_psnr;
  return summary;
}

}  // namespace lrf::splat
