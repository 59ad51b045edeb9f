#pragma once
// lrf's exit status, one scheme for every command (listed by `lrf --help`, kExitStatusHelp):
//   0 the command did its work; 1 it failed (bad input data, a missing file or model, a runtime error);
//   2 the command line is wrong (unknown command or option, a bad option value), nothing was done;
//   128 + N when signal N stopped a training job (130: Ctrl-C / SIGINT, 143: SIGTERM), as shells report
//   a process a signal ended; the job first wrote a checkpoint, which --resume continues from.
namespace lrf::cli {

constexpr int kExitOk = 0;
constexpr int kExitFailed = 1;
constexpr int kExitUsage = 2;

constexpr const char* kExitStatusHelp =
    "Exit status: 0 done; 1 failed (bad input data, a missing file or model, a runtime error); 2 usage error "
    "(unknown command or option, a bad option value: nothing was done); 130 stopped by Ctrl-C (SIGINT), 143 by "
    "SIGTERM: a training job stops at its next step, writes a checkpoint and exits, and --resume continues it.";

}  // namespace lrf::cli
