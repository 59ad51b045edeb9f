#include "lrf/finetune/finetune_output.h"

#include <filesystem>

#include "lrf/core/error.h"

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

}  // namespace lrf
