#pragma once
// An exclusive lock on an output folder for as long as a job writes it: flock(2) on FOLDER/.lock, so the
// kernel releases it when the process ends in any way (kill -9 included) and a stale lock never blocks a
// later run. The holder writes its PID into the file; a second job is refused with an error naming the
// folder and that PID. A job whose output is one file (OUT.safetensors beside OUT.json and its
// checkpoint) locks OUT.lock instead, through for_output_file. The holder removes the lock file when it
// releases the lock (a process killed outright leaves it, unlocked and harmless), so that a finished or
// failed job leaves no .lock behind.
#include <string>

namespace lrf {

class FolderLock {
 public:
  // Creates FOLDER/.lock if needed (the folder must exist) and takes the lock, or throws lrf::Error.
  explicit FolderLock(const std::string& folder);
  ~FolderLock();
  FolderLock(FolderLock&& other) noexcept;
  FolderLock& operator=(FolderLock&& other) noexcept;
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;

  // Locks OUTPUT.lock (OUTPUT's folder must exist): for jobs that write one file and its companions.
  static FolderLock for_output_file(const std::string& output);

  static std::string lock_file(const std::string& folder);

 private:
  // subject: the folder or file named in errors; what: "output folder" or "output file".
  FolderLock(const std::string& lock_path, const std::string& subject, const std::string& what);
  // Removes the lock file and releases the lock (nothing when not held).
  void release();

  int fd_ = -1;
  std::string path_;
};

}  // namespace lrf
