#include "lrf/core/stop_request.h"

#include <csignal>
#include <cstdint>
#include <cstring>

namespace lrf {
namespace {

volatile std::sig_atomic_t g_signal = 0;
int g_depth = 0;  // nested StopOnSignals (the loops run on the main thread, one at a time)
struct sigaction g_previous_int {}, g_previous_term {};

void on_signal(int signal) { g_signal = signal; }

}  // namespace

StopOnSignals::StopOnSignals() {
  if (g_depth++ > 0) return;
  g_signal = 0;
  struct sigaction action {};
  action.sa_handler = on_signal;
  sigemptyset(&action.sa_mask);
  // SA_RESETHAND: the first signal only asks; the next one has the default effect (the process ends).
  // SA_RESTART: a file being written when the signal comes is written on, not failed with EINTR.
  action.sa_flags = SA_RESETHAND | SA_RESTART;
  sigaction(SIGINT, &action, &g_previous_int);
  sigaction(SIGTERM, &action, &g_previous_term);
}

StopOnSignals::~StopOnSignals() {
  if (--g_depth > 0) return;
  sigaction(SIGINT, &g_previous_int, nullptr);
  sigaction(SIGTERM, &g_previous_term, nullptr);
}

int stop_signal() { return g_signal; }

void throw_interrupted(int64_t step, const std::string& checkpoint) {
  const int signal = stop_signal() ? stop_signal() : SIGINT;
  const char* name = signal == SIGTERM ? "SIGTERM" : signal == SIGINT ? "SIGINT" : strsignal(signal);
  throw Interrupted(signal, std::string("stopped by ") + name + " after step " + std::to_string(step) + "; " +
                                checkpoint + " holds it: continue with --resume");
}

}  // namespace lrf
