#include "lrf/scene/colmap_program.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <fstream>
#include <regex>
#include <thread>

#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/progress.h"
#include "lrf/core/stop_request.h"

extern char** environ;

namespace lrf {
namespace {

// The shell sees every argument as one word, whatever characters a path holds.
std::string shell_quoted(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// COLMAP's own progress, read from the end of its log: the last line that says how far a step is.
// Matching every pair of a few dozen photos took 9.5 minutes without a word on the terminal.
std::string colmap_progress(const std::string& log, const std::string& step) {
  std::ifstream in(log, std::ios::binary);
  if (!in) return "";
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  const std::streamoff tail = std::min<std::streamoff>(size, 64 * 1024);
  std::string text(static_cast<size_t>(tail), '\0');
  in.seekg(size - tail);
  in.read(text.data(), tail);
  // Only this step's own lines: the log holds every step's.
  const size_t heading = text.rfind("==== lrf scene create: colmap " + step);
  if (heading != std::string::npos) text = text.substr(heading);
  static const std::regex kLine(R"((Processed file \[\d+/\d+\])|(Matching block \[\d+/\d+, \d+/\d+\])|)"
                                R"((Matching image \[\d+/\d+\])|(Registering image #\d+ \(\d+\))|(Undistorting image \[\d+/\d+\]))");
  std::string last;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), kLine); it != std::sregex_iterator(); ++it)
    last = it->str();
  if (last.rfind("Registering image", 0) == 0) {
    const size_t open = last.find('(');
    return "registering photos (" + last.substr(open + 1, last.size() - open - 2) + " registered so far)";
  }
  return last;
}

// Ends COLMAP and whatever it started: SIGTERM to its process group, SIGKILL after 5 s; reaps it.
void stop_child(pid_t pid) {
  ::kill(-pid, SIGTERM);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  int status = 0;
  while (::waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > deadline) {
      ::kill(-pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      return;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

}  // namespace

bool colmap_available(const std::string& colmap) {
  return std::system((shell_quoted(colmap) + " help > /dev/null 2>&1").c_str()) == 0;
}

std::string file_tail(const std::string& path, int lines) {
  std::ifstream in(path);
  std::deque<std::string> last;
  std::string line;
  while (std::getline(in, line)) {
    last.push_back(line);
    if (static_cast<int>(last.size()) > lines) last.pop_front();
  }
  std::string out;
  for (const auto& l : last) out += l + "\n";
  return out;
}

void run_colmap(const std::string& colmap, const std::string& step, const std::vector<std::string>& args,
                const std::string& log) {
  const int out = ::open(log.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
  if (out < 0) fail(log, std::string("cannot open COLMAP's log: ") + std::strerror(errno));
  std::vector<std::string> words = {colmap, step};
  words.insert(words.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& w : words) argv.push_back(w.data());
  argv.push_back(nullptr);

  // COLMAP runs in a process group of its own, so that a terminal's Ctrl-C reaches lrf alone: lrf then
  // stops COLMAP and everything it started, and exits as a stopped job (std::system ignored Ctrl-C while
  // COLMAP ran, and SIGTERM left COLMAP running, holding the database a retry needed).
  StopOnSignals stop_on_signals;
  posix_spawn_file_actions_t files;
  posix_spawn_file_actions_init(&files);
  posix_spawn_file_actions_adddup2(&files, out, 1);
  posix_spawn_file_actions_adddup2(&files, out, 2);
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  sigset_t defaults;
  sigemptyset(&defaults);
  for (const int s : {SIGINT, SIGTERM, SIGPIPE, SIGQUIT}) sigaddset(&defaults, s);
  posix_spawnattr_setsigdefault(&attributes, &defaults);
  posix_spawnattr_setpgroup(&attributes, 0);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP | POSIX_SPAWN_SETSIGDEF);
  pid_t pid = -1;
  const int spawned = ::posix_spawnp(&pid, argv[0], &files, &attributes, argv.data(), environ);
  posix_spawn_file_actions_destroy(&files);
  posix_spawnattr_destroy(&attributes);
  ::close(out);
  if (spawned != 0) fail("cannot run '" + colmap + "': " + std::strerror(spawned));

  const auto start = std::chrono::steady_clock::now();
  auto next_report = start + std::chrono::seconds(15);
  std::string reported;
  int status = 0;
  for (;;) {
    const pid_t done = ::waitpid(pid, &status, WNOHANG);
    if (done == pid) break;
    if (done < 0 && errno != EINTR) {
      status = -1;
      break;
    }
    if (const int signal = stop_signal()) {
      stop_child(pid);
      throw Interrupted(signal, std::string("stopped by ") + (signal == SIGINT ? "SIGINT" : "SIGTERM") + " during colmap " +
                                    step + ", which was stopped too; the same command again starts over from this "
                                    "step (the steps before it are kept)");
    }
    const auto now = std::chrono::steady_clock::now();
    if (now >= next_report) {
      next_report = now + std::chrono::seconds(15);
      const std::string progress = colmap_progress(log, step);
      const double elapsed = std::chrono::duration<double>(now - start).count();
      if (!progress.empty() && progress != reported)
        log_info("    " + progress + " (" + Progress::format_duration(elapsed) + " so far)");
      reported = progress;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  const int code = status == -1 ? -1 : (WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status));
  if (code != 0) {
    fail(log, "colmap " + step + " failed (exit code " + std::to_string(code) + "); the end of its output:\n" +
                  file_tail(log, 15));
  }
}

}  // namespace lrf
