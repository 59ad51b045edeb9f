#pragma once
// Running the `colmap` program (an optional dependency: Debian's colmap package) as a child process, its
// output appended to a log file so that the terminal shows lrf's own progress only.
#include <string>
#include <vector>

namespace lrf {

// True when `colmap` can be run (`colmap help` exits with 0); a bare name is looked up on PATH.
bool colmap_available(const std::string& colmap = "colmap");

// Runs `colmap <step> <args...>` with stdout and stderr appended to `log`. Throws lrf::Error naming the
// step, its exit code and the log, with the log's last lines, when it fails.
void run_colmap(const std::string& colmap, const std::string& step, const std::vector<std::string>& args,
                const std::string& log);

// The last `lines` lines of a text file ("" when it cannot be read).
std::string file_tail(const std::string& path, int lines);

}  // namespace lrf
