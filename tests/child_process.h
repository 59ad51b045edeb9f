#pragma once
// Child processes for the end-to-end tests of long-running commands (lrf serve, a browser): started with
// fork/exec, their stdout readable line by line with a deadline, stopped (SIGTERM, then SIGKILL) and
// reaped by the destructor.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace lrf::test {

class ChildProcess {
 public:
  // Runs argv[0] with `argv`; stdout is captured when `capture_stdout`, stderr goes to `stderr_path`
  // ("" = inherited). `extra_fds` are (parent fd, child fd) pairs dup'ed into the child.
  ChildProcess(const std::vector<std::string>& argv, bool capture_stdout, const std::string& stderr_path = "",
               const std::vector<std::pair<int, int>>& extra_fds = {}) {
    int out[2] = {-1, -1};
    if (capture_stdout && ::pipe(out) != 0) throw std::runtime_error("pipe failed");
    pid_ = ::fork();
    if (pid_ < 0) throw std::runtime_error("fork failed");
    if (pid_ == 0) {
      // Move every fd we hand over above the targets first, so that dup2 never clobbers a source.
      std::vector<std::pair<int, int>> fds;
      for (auto [from, to] : extra_fds) fds.emplace_back(::fcntl(from, F_DUPFD, 100), to);
      for (auto [from, to] : fds) ::dup2(from, to);
      if (capture_stdout) ::dup2(out[1], 1);
      if (!stderr_path.empty()) {
        const int err = ::open(stderr_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (err >= 0) ::dup2(err, 2);
      }
      // Nothing else of the test process (its other pipes and sockets) leaks into the child.
      for (int fd = 3 + static_cast<int>(extra_fds.size()); fd < 1024; ++fd) ::close(fd);
      std::vector<char*> args;
      for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
      args.push_back(nullptr);
      ::execv(args[0], args.data());
      ::_exit(127);
    }
    if (capture_stdout) {
      ::close(out[1]);
      stdout_ = out[0];
    }
  }
  ~ChildProcess() { stop(); }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  // The next line of stdout ("" at end of file or after `seconds`).
  std::string read_line(double seconds) {
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(seconds));
    while (true) {
      const size_t nl = buffer_.find('\n');
      if (nl != std::string::npos) {
        std::string line = buffer_.substr(0, nl);
        buffer_.erase(0, nl + 1);
        return line;
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0 || stdout_ < 0) return "";
      pollfd p{stdout_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) continue;
      char buf[4096];
      const ssize_t n = ::read(stdout_, buf, sizeof buf);
      if (n <= 0) return "";
      buffer_.append(buf, static_cast<size_t>(n));
    }
  }

  // SIGTERM, up to `seconds` to exit, then SIGKILL; returns the exit status (-1 when killed).
  int stop(double seconds = 10) {
    if (pid_ <= 0) return status_;
    ::kill(pid_, SIGTERM);
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(seconds));
    int status = 0;
    while (::waitpid(pid_, &status, WNOHANG) == 0) {
      if (std::chrono::steady_clock::now() > deadline) {
        ::kill(pid_, SIGKILL);
        ::waitpid(pid_, &status, 0);
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    status_ = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    pid_ = -1;
    if (stdout_ >= 0) ::close(stdout_);
    stdout_ = -1;
    return status_;
  }
  // Waits for the process to end by itself (up to `seconds`, then as stop()).
  int wait(double seconds) {
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(seconds));
    int status = 0;
    while (pid_ > 0 && std::chrono::steady_clock::now() < deadline) {
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        status_ = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
        pid_ = -1;
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return stop();
  }
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  int stdout_ = -1;
  int status_ = -1;
  std::string buffer_;
};

}  // namespace lrf::test
