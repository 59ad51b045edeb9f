#include "lrf/core/run_loop.h"

#include <optional>

#include "lrf/core/expected_time.h"
#include "lrf/core/progress.h"
#include "lrf/core/stop_request.h"

namespace lrf {

int64_t run_loop(const RunLoop& l) {
  const StopOnSignals stop_on_signals;
  std::optional<ExpectedTimeNotice> expected;
  if (!l.expected_time_note.empty() && l.progress)
    expected.emplace(l.total_steps - l.first_step, l.expected_time_note, l.prepared_seconds);
  int64_t done = l.first_step, saved = -1;
  auto save = [&] {
    l.save();
    saved = done;
  };
  while (done < l.total_steps) {
    const LoopStep r = l.step();
    done = r.steps_done;
    if (l.progress) l.progress->update(done, r.shown);
    if (expected) expected->observe(done - l.first_step, l.progress->elapsed_seconds());
    if (done >= l.total_steps) break;
    if (l.checkpoint_every > 0 && done % l.checkpoint_every == 0) save();
    if (l.stop_requested ? l.stop_requested() : stop_signal() != 0) {
      if (saved != done) save();
      throw_interrupted(done, l.checkpoint);
    }
  }
  save();
  return done;
}

}  // namespace lrf
