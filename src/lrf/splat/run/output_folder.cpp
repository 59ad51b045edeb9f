#include "lrf/splat/run/output_folder.h"

#include <exception>
#include <filesystem>
#include <utility>

#include "lrf/splat/run/train_run.h"

namespace fs = std::filesystem;

namespace lrf::splat {

OutputFolder::OutputFolder(FolderLock lock, std::string path, std::vector<std::string> created)
    : lock_(std::move(lock)), path_(std::move(path)), created_(std::move(created)),
      exceptions_(std::uncaught_exceptions()) {}

OutputFolder::OutputFolder(OutputFolder&& other) noexcept
    : lock_(std::move(other.lock_)), path_(std::move(other.path_)), created_(std::exchange(other.created_, {})),
      exceptions_(other.exceptions_) {}

OutputFolder::~OutputFolder() {
  if (created_.empty() || std::uncaught_exceptions() <= exceptions_ || holds_checkpoint(path_)) return;
  std::error_code ec;
  fs::remove_all(path_, ec);  // the lock file too; the lock itself goes with lock_ just after
  // Parents only when empty: another job may have put its own output beside this one meanwhile.
  for (size_t k = 1; k < created_.size() && !ec; ++k) fs::remove(created_[k], ec);
}

bool holds_checkpoint(const std::string& out) {
  std::error_code ec;
  // The latent NeRF's file is nerf_checkpoint_path's (nerf/nerf_run.h), named here since splat/ does not
  // include nerf/.
  return fs::exists(checkpoint_path(out), ec) || fs::exists(fs::path(out) / "checkpoint.safetensors", ec);
}

std::vector<std::string> missing_folders(const std::string& path) {
  std::vector<std::string> missing;
  std::error_code ec;
  fs::path start = fs::absolute(path).lexically_normal();
  if (start.filename().empty()) start = start.parent_path();  // "out/" names the folder "out"
  for (fs::path p = start; !p.empty() && !fs::exists(p, ec); p = p.parent_path()) {
    missing.push_back(p.string());
    if (p == p.parent_path()) break;
  }
  return missing;
}

}  // namespace lrf::splat
