#pragma once
// `lrf launch -n N -- COMMAND...`: starts N ranks of a data-parallel command on this host, as torchrun
// does: each child gets RANK, LOCAL_RANK, WORLD_SIZE, MASTER_ADDR and MASTER_PORT (a free port unless
// MASTER_PORT is set). Ctrl-C (SIGINT) and SIGTERM are forwarded to every rank (a second Ctrl-C kills
// them); when a rank fails, the others get `grace_seconds` to stop on their own (they notice within
// their timeout and say which rank stopped) before they are terminated.
#include <string>
#include <vector>

namespace lrf {

struct LaunchOptions {
  int ranks = 1;
  std::vector<std::string> command;  // program and arguments; "lrf" means this program
  int master_port = 0;               // 0: $MASTER_PORT, else a free port
  int threads_per_rank = 0;          // lrf commands without --threads get this many (0: cores / ranks)
  double grace_seconds = 30;
};

// Runs the ranks to the end; returns 0 if every rank succeeded, else the first failed rank's exit status
// (128 + signal for a rank killed by a signal). Throws lrf::Error if a rank cannot be started.
int launch_local(const LaunchOptions& options);

}  // namespace lrf
