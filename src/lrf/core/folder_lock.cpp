#include "lrf/core/folder_lock.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <utility>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include "lrf/core/error.h"

namespace lrf {
namespace {

// The PID the holder wrote, or "" (the holder may not have written it yet).
std::string holder_pid(int fd) {
  char buf[32] = {0};
  ssize_t n = ::pread(fd, buf, sizeof buf - 1, 0);
  std::string s = n > 0 ? std::string(buf, static_cast<size_t>(n)) : "";
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  for (char c : s)
    if (c < '0' || c > '9') return "";
  return s;
}

// Whether `path` still names the file open as `fd`: a holder removes the lock file when it releases it, so
// a job that opened the file before the removal and locked it after holds a lock nobody else will see.
bool names_open_file(const std::string& path, int fd) {
  struct stat named {}, opened {};
  return ::stat(path.c_str(), &named) == 0 && ::fstat(fd, &opened) == 0 && named.st_dev == opened.st_dev &&
         named.st_ino == opened.st_ino;
}

}  // namespace

std::string FolderLock::lock_file(const std::string& folder) { return (std::filesystem::path(folder) / ".lock").string(); }

FolderLock::FolderLock(const std::string& folder) : FolderLock(lock_file(folder), folder, "output folder") {}

FolderLock FolderLock::for_output_file(const std::string& output) {
  return FolderLock(output + ".lock", output, "output file");
}

FolderLock::FolderLock(const std::string& path, const std::string& subject, const std::string& what) : path_(path) {
  while (true) {
    // O_CLOEXEC: a program this process starts must not inherit (and outlive it holding) the lock.
    fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) fail(subject, "cannot create the lock file " + path + ": " + std::strerror(errno));
    while (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      const std::string pid = err == EWOULDBLOCK ? holder_pid(fd_) : "";
      ::close(fd_);
      fd_ = -1;
      if (err != EWOULDBLOCK) fail(subject, "cannot lock the " + what + ": " + std::strerror(err));
      fail(subject, what + " is in use by another lrf job (" +
                        (pid.empty() ? std::string("PID unknown") : "PID " + pid) +
                        "); wait for it to finish or stop it, or choose another one");
    }
    if (names_open_file(path, fd_)) break;
    ::close(fd_);  // the previous holder removed the file in between: lock the one the path names now
  }
  const std::string mine = std::to_string(::getpid()) + "\n";
  if (::ftruncate(fd_, 0) != 0 || ::pwrite(fd_, mine.data(), mine.size(), 0) != static_cast<ssize_t>(mine.size())) {
    // The lock holds without the PID; only the message of a refused second job is poorer.
  }
}

void FolderLock::release() {
  if (fd_ < 0) return;
  ::unlink(path_.c_str());  // while still locked: a job waiting on this file retries on the new one
  ::close(fd_);             // closing the last descriptor releases the lock
  fd_ = -1;
}

FolderLock::~FolderLock() { release(); }

FolderLock::FolderLock(FolderLock&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)), path_(std::move(other.path_)) {}

FolderLock& FolderLock::operator=(FolderLock&& other) noexcept {
  if (this != &other) {
    release();
    fd_ = std::exchange(other.fd_, -1);
    path_ = std::move(other.path_);
  }
  return *this;
}

}  // namespace lrf
