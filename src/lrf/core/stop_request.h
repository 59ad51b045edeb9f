#pragma once
// Ctrl-C (SIGINT) and SIGTERM as a request to stop a training job at its next step boundary, after it
// writes a checkpoint, instead of killing it at once (which lost every step since the last checkpoint).
// A training loop holds a StopOnSignals while it runs and checks stop_signal() between steps; outside one
// the signals keep their effect, so that `lrf render` or a scene being encoded still stop at once. A second
// signal while a stop is pending ends the process at once, as if there were no handler.
#include <cstdint>
#include <string>

#include "lrf/core/error.h"

namespace lrf {

class StopOnSignals {
 public:
  // Installs the handlers and clears any earlier request (nested scopes share the outermost one's).
  StopOnSignals();
  // Puts back the handlers that were there before.
  ~StopOnSignals();
  StopOnSignals(const StopOnSignals&) = delete;
  StopOnSignals& operator=(const StopOnSignals&) = delete;
};

// The signal that asked to stop (SIGINT or SIGTERM) since the outermost StopOnSignals began, or 0.
int stop_signal();

// Thrown by a training loop that stopped on request after writing its checkpoint. The CLI exits with
// exit_status(): 128 + the signal, as shells report a process that a signal ended (130 for Ctrl-C).
class Interrupted : public Error {
 public:
  Interrupted(int signal, const std::string& what) : Error(what), signal_(signal) {}
  int exit_status() const { return 128 + signal_; }

 private:
  int signal_;
};

// Throws Interrupted for stop_signal() (SIGINT when another process of a data-parallel group asked):
// "stopped by SIGINT after step N; CHECKPOINT holds it: continue with --resume".
[[noreturn]] void throw_interrupted(int64_t step, const std::string& checkpoint);

}  // namespace lrf
