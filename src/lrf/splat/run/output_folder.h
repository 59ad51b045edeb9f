#pragma once
// An output folder claimed by a training job (prepare_output_dir in train_run.h): its lock, held for as
// long as the job writes the folder, and the clean-up after a job that fails before it wrote anything worth
// keeping. A folder the job created is removed again (with the parent folders it created, when they are
// left empty) if the job ends by an exception while the folder holds no checkpoint: a scene, model or split
// error, a bad image, a divergence before the first checkpoint. A second attempt then starts as the first
// did, without --force or --resume. A folder that existed before is never removed.
#include <string>
#include <vector>

#include "lrf/core/folder_lock.h"

namespace lrf::splat {

class OutputFolder {
 public:
  // `created`: the folders that claiming `path` created, `path` first, then its new parents outwards.
  OutputFolder(FolderLock lock, std::string path, std::vector<std::string> created);
  ~OutputFolder();
  OutputFolder(OutputFolder&& other) noexcept;
  OutputFolder& operator=(OutputFolder&&) = delete;
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;

 private:
  FolderLock lock_;
  std::string path_;
  std::vector<std::string> created_;
  // std::uncaught_exceptions() when the folder was claimed: more when it is released means the job is
  // being unwound by an exception, i.e. it failed.
  int exceptions_;
};

// Whether OUT holds a checkpoint a job can resume from: a Gaussian field's checkpoint.pt or a latent
// NeRF's checkpoint.safetensors.
bool holds_checkpoint(const std::string& out);

// The folders that creating `path` would create: `path` itself and each missing parent, outwards; empty
// when `path` exists.
std::vector<std::string> missing_folders(const std::string& path);

}  // namespace lrf::splat
