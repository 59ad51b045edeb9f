#pragma once
// What every training job's options say about the job's output: where it goes, whether an existing one is
// resumed or replaced, and how often the job checkpoints. Each job's options derive from it, and the job's
// run loop is made from it whole, so a setting of it reaches every job without a line in each.
#include <cstdint>
#include <string>

namespace lrf {

struct RunControl {
  std::string out;
  bool resume = false, force = false;
  int64_t checkpoint_every = 1000;
};

}  // namespace lrf
