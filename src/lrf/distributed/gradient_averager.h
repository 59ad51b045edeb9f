#pragma once
// Averages the gradients of a set of parameters over the ranks of a DataParallelGroup while the backward
// pass runs, the way PyTorch DDP does (Debian's libtorch ships DDP's Reducer without the headers it needs,
// so the same scheme is written here on the process group's all-reduce): the parameters are packed in
// reverse order (roughly the order the backward produces their gradients) into buckets of at most 1 MiB
// for the first and 25 MiB for the others; a hook on each parameter copies its gradient into its bucket,
// and a bucket's all-reduce starts, in bucket order on every rank, as soon as its last gradient is in,
// while the backward goes on through earlier layers. finish_step() waits for the all-reduces and leaves
// the mean over the ranks in every parameter's .grad(). A parameter no rank's loss reached keeps no
// gradient, as in one process (the last bucket also carries, per parameter, how many ranks used it).
// In a group of one process it does nothing.
#include <memory>
#include <vector>

#include <ATen/Tensor.h>

#include "lrf/distributed/data_parallel_group.h"

namespace lrf {

class GradientAverager {
 public:
  // The parameters must be the same, in the same order, on every rank.
  GradientAverager(DataParallelGroup& group, std::vector<at::Tensor> parameters);
  ~GradientAverager();
  GradientAverager(const GradientAverager&) = delete;
  GradientAverager& operator=(const GradientAverager&) = delete;

  // Every rank, every step: begin_step() before the backward, finish_step() after it.
  void begin_step();
  void finish_step();
  int buckets() const;

  struct State;

 private:
  std::shared_ptr<State> state_;
};

}  // namespace lrf
