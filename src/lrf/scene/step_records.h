#pragma once
// Resumable multi-step jobs: each finished step leaves a record of what it was given (its own settings
// chained after those of the steps before it). A rerun skips a step whose record matches; a step that
// must run again makes every later one run again too, since its inputs have changed.
#include <string>

namespace lrf {

class StepRecords {
 public:
  // Records live in `dir` as <step>.done; `start_over` ignores them all (and removes them as steps rerun).
  StepRecords(std::string dir, bool start_over);

  // Adds `settings` to the chain. True when this step may be skipped: nothing before it ran again, its
  // record matches the chain so far and `output_present`. Otherwise removes its record, and every later
  // step will also run.
  bool skip(const std::string& step, const std::string& settings, bool output_present);
  // Marks `step` finished with the chain so far; call only after its output is complete.
  void finished(const std::string& step);

 private:
  std::string path(const std::string& step) const;
  std::string dir_;
  std::string chain_;
  bool rerun_;
};

}  // namespace lrf
