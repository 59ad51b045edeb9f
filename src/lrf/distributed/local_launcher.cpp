#include "lrf/distributed/local_launcher.h"

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <optional>
#include <thread>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include "lrf/core/error.h"
#include "lrf/core/log.h"

namespace lrf {
namespace {

volatile std::sig_atomic_t g_signals = 0;
volatile std::sig_atomic_t g_last_signal = 0;

void on_signal(int sig) {
  g_signals = g_signals + 1;
  g_last_signal = sig;
}

// A port nobody listens on right now (the kernel's choice), for rank 0's rendezvous.
int free_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) fail("launch: cannot open a socket to find a free port: " + std::string(std::strerror(errno)));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  socklen_t len = sizeof addr;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
    ::close(fd);
    fail("launch: cannot find a free port: " + std::string(std::strerror(errno)));
  }
  ::close(fd);
  return ntohs(addr.sin_port);
}

std::string describe_status(int status) {
  if (WIFSIGNALED(status)) return "was killed by signal " + std::to_string(WTERMSIG(status)) + " (" + strsignal(WTERMSIG(status)) + ")";
  return "exited with status " + std::to_string(WEXITSTATUS(status));
}

int exit_code_of(int status) { return WIFSIGNALED(status) ? 128 + WTERMSIG(status) : WEXITSTATUS(status); }

// The child's argument list: "lrf" becomes this program, and an lrf command without --threads gets
// `threads` so that the ranks share the cores instead of each taking all of them.
std::vector<std::string> child_arguments(const LaunchOptions& o, int threads) {
  std::vector<std::string> args = o.command;
  const std::string self = std::filesystem::read_symlink("/proc/self/exe").string();
  const bool is_lrf = args[0] == "lrf" || args[0] == self;
  if (args[0] == "lrf") args[0] = self;
  if (is_lrf) {
    bool has_threads = false;
    for (const auto& a : args) has_threads = has_threads || a == "--threads" || a.rfind("--threads=", 0) == 0;
    if (!has_threads) args.insert(args.begin() + 1, {"--threads", std::to_string(threads)});
  }
  return args;
}

}  // namespace

int launch_local(const LaunchOptions& o) {
  if (o.ranks < 1) fail("launch: -n must be at least 1");
  if (o.command.empty()) fail("launch: no command after --");
  int port = o.master_port;
  if (port == 0) {
    const char* env = std::getenv("MASTER_PORT");
    port = env && *env ? std::atoi(env) : free_port();
  }
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const int threads = o.threads_per_rank > 0 ? o.threads_per_rank : std::max(1, cores / o.ranks);
  const std::vector<std::string> args = child_arguments(o, threads);

  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  struct sigaction old_int {}, old_term {};
  sigaction(SIGINT, &sa, &old_int);
  sigaction(SIGTERM, &sa, &old_term);

  log_info("launch: " + std::to_string(o.ranks) + " ranks on 127.0.0.1:" + std::to_string(port) + ", " +
           std::to_string(threads) + " thread(s) each");
  std::vector<pid_t> pids;
  for (int r = 0; r < o.ranks; ++r) {
    const pid_t pid = ::fork();
    if (pid < 0) {
      for (pid_t p : pids) ::kill(p, SIGKILL);
      fail("launch: cannot start rank " + std::to_string(r) + ": " + std::strerror(errno));
    }
    if (pid == 0) {
      // Its own process group: a Ctrl-C reaches the launcher, which forwards it once to every rank.
      ::setpgid(0, 0);
      ::signal(SIGINT, SIG_DFL);
      ::signal(SIGTERM, SIG_DFL);
      ::setenv("RANK", std::to_string(r).c_str(), 1);
      ::setenv("LOCAL_RANK", std::to_string(r).c_str(), 1);
      ::setenv("WORLD_SIZE", std::to_string(o.ranks).c_str(), 1);
      ::setenv("MASTER_ADDR", "127.0.0.1", 1);
      ::setenv("MASTER_PORT", std::to_string(port).c_str(), 1);
      if (!std::getenv("OMP_NUM_THREADS")) ::setenv("OMP_NUM_THREADS", std::to_string(threads).c_str(), 1);
      std::vector<char*> argv;
      for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      ::execvp(argv[0], argv.data());
      std::fprintf(stderr, "launch: cannot run %s: %s\n", argv[0], std::strerror(errno));
      ::_exit(127);
    }
    pids.push_back(pid);
  }

  using clock = std::chrono::steady_clock;
  std::vector<bool> running(pids.size(), true);
  size_t left = pids.size();
  int result = 0;
  int forwarded = 0;
  std::optional<clock::time_point> failed_at;
  bool terminated = false;
  while (left > 0) {
    int status = 0;
    const pid_t done = ::waitpid(-1, &status, WNOHANG);
    if (done > 0) {
      for (size_t r = 0; r < pids.size(); ++r) {
        if (pids[r] != done || !running[r]) continue;
        running[r] = false;
        --left;
        const bool ok = WIFEXITED(status) && WEXITSTATUS(status) == 0;
        if (!ok) {
          log_error("launch: rank " + std::to_string(r) + " (pid " + std::to_string(done) + ") " + describe_status(status));
          if (result == 0) result = exit_code_of(status);
          if (!failed_at) failed_at = clock::now();
        }
      }
      continue;
    }
    if (g_signals > forwarded) {
      forwarded = g_signals;
      const int sig = forwarded > 1 ? SIGKILL : static_cast<int>(g_last_signal);
      log_warn("launch: forwarding " + std::string(strsignal(sig)) + " to every rank");
      for (size_t r = 0; r < pids.size(); ++r) {
        if (running[r]) ::kill(pids[r], sig);
      }
      if (result == 0) result = 128 + static_cast<int>(g_last_signal);
    }
    if (failed_at && !terminated &&
        std::chrono::duration<double>(clock::now() - *failed_at).count() > o.grace_seconds) {
      log_error("launch: the other ranks did not stop within " + std::to_string(static_cast<int>(o.grace_seconds)) +
                " s of the failure; terminating them");
      for (size_t r = 0; r < pids.size(); ++r) {
        if (running[r]) ::kill(pids[r], SIGTERM);
      }
      terminated = true;
      failed_at = clock::now();
    } else if (terminated && std::chrono::duration<double>(clock::now() - *failed_at).count() > 5) {
      for (size_t r = 0; r < pids.size(); ++r) {
        if (running[r]) ::kill(pids[r], SIGKILL);
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  sigaction(SIGINT, &old_int, nullptr);
  sigaction(SIGTERM, &old_term, nullptr);
  return result;
}

}  // namespace lrf
