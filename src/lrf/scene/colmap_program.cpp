#include "lrf/scene/colmap_program.h"

#include <sys/wait.h>

#include <cstdlib>
#include <deque>
#include <fstream>

#include "lrf/core/error.h"

namespace lrf {
namespace {

// The shell sees every argument as one word, whatever characters a path holds.
std::string shell_quoted(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
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
  std::string cmd = shell_quoted(colmap) + " " + step;
  for (const auto& a : args) cmd += " " + shell_quoted(a);
  cmd += " >> " + shell_quoted(log) + " 2>&1";
  const int status = std::system(cmd.c_str());
  const int code = status == -1 ? -1 : (WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status));
  if (code != 0) {
    fail(log, "colmap " + step + " failed (exit code " + std::to_string(code) + "); the end of its output:\n" +
                  file_tail(log, 15));
  }
}

}  // namespace lrf
