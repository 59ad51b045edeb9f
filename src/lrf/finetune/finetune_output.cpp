#include "lrf/finetune/finetune_output.h"

#include <filesystem>

#include "lrf/core/error.h"
#include "lrf/core/log.h"

namespace lrf {

FolderLock claim_finetune_output(const std::string& out, const std::string& checkpoint, bool force, bool resume) {
  namespace fs = std::filesystem;
  if (fs::path(out).has_parent_path()) fs::create_directories(fs::path(out).parent_path());
  FolderLock lock = FolderLock::for_output_file(out);
  if (fs::exists(out) && !force && !resume) fail(out, "already exists (use --force to overwrite)");
  if (resume && !fs::exists(checkpoint)) fail(checkpoint, "no checkpoint to resume from");
  return lock;
}

void fail_non_finite_loss(const std::string& out, double loss, int64_t step, const std::string& checkpoint) {
  fail(out, "loss is " + std::to_string(loss) + " at step " + std::to_string(step) +
                "; stopped (the last checkpoint, if any, is " + checkpoint + ")");
}

std::pair<std::string, std::string> precision_metadata(Precision precision) {
  return {"lrf_precision", precision_name(precision)};
}

void warn_if_precision_changed(const std::map<std::string, std::string>& checkpoint_metadata, Precision now,
                               const std::string& checkpoint) {
  auto it = checkpoint_metadata.find("lrf_precision");
  // Checkpoints from before precisions existed were written in fp32.
  const std::string then = it == checkpoint_metadata.end() ? "fp32" : it->second;
  if (then != precision_name(now)) {
    log_warn(checkpoint + " was written by steps in " + then + ", resuming in " + precision_name(now) +
             ": the result will differ (by rounding) from an uninterrupted run (pass --precision " + then +
             " to reproduce it)");
  }
}

}  // namespace lrf
