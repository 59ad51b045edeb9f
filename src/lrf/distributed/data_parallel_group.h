#pragma once
// The ranks of one data-parallel job and the few collectives the fine-tuning loop needs, on PyTorch's
// own distributed stack (c10d): a TCPStore on rank 0 for the rendezvous and a Gloo process group for
// the collectives. A group of one process does no communication at all.
//
// Failures: a collective that waits longer than the timeout fails (a hung rank), a dead rank's closed
// sockets fail it at once; either way every rank's heartbeat, kept in the store, tells the survivors
// which rank stopped, so that fail_step() can name it.
#include <memory>
#include <string>
#include <vector>

#include <ATen/Tensor.h>
#include <nlohmann/json.hpp>

#include "lrf/distributed/distributed_options.h"

namespace lrf {

class DataParallelGroup {
 public:
  // A job of one process.
  DataParallelGroup();
  // Joins the job `options` describes (resolved; world size > 1): every rank must call this, and it
  // returns once all have arrived (or throws after the timeout). `job` names the command in messages.
  DataParallelGroup(const DistributedOptions& options, const std::string& job);
  ~DataParallelGroup();
  DataParallelGroup(const DataParallelGroup&) = delete;
  DataParallelGroup& operator=(const DataParallelGroup&) = delete;

  int rank() const { return rank_; }
  int world_size() const { return world_size_; }
  bool is_main() const { return rank_ == 0; }
  bool distributed() const { return world_size_ > 1; }
  // "rank 1 of 2: " (empty for one process), to prefix messages.
  std::string prefix() const;

  // Element-wise sum over the ranks, in place (doubles travel exactly).
  void sum(std::vector<double>& values);
  // Element-wise sum over the ranks of a dense tensor, in place.
  void sum(const at::Tensor& values);
  // Rank 0's `value` on every rank (through the store; for short texts such as a refusal to start).
  std::string from_main(const std::string& key, const std::string& value);
  // Overwrites every rank's `tensors` with rank 0's (same shapes and types on every rank).
  void broadcast_from_main(const std::vector<at::Tensor>& tensors);
  // Every rank passes what stops it from starting ("" if nothing): if any rank cannot start, every rank
  // throws, naming each such rank and its reason. Without it, the others would wait for it in vain.
  void start_together(const std::string& problem);
  // Refuses to start unless every rank describes its options and inputs with the same JSON as rank 0:
  // throws on every rank, naming the ranks and the settings that differ.
  void require_same_as_main(const nlohmann::json& description, const std::string& what);
  // Waits for every rank.
  void barrier();

  // Called when `error` stopped this rank at `where`: finds out whether another rank died, hung or
  // failed first (heartbeats and posted errors) and throws an lrf::Error naming it; if not, posts this
  // rank's own error for the others to read and throws it. `advice` ends the message (e.g. where the
  // last checkpoint is).
  [[noreturn]] void fail_step(const std::string& where, const std::string& error, const std::string& advice);

  struct Impl;
  Impl& impl() { return *impl_; }

 private:
  int rank_ = 0, world_size_ = 1;
  std::unique_ptr<Impl> impl_;
};

// The group `options` describe: one process when the world size is 1 or unset (< 1), else joins the job.
std::unique_ptr<DataParallelGroup> join_data_parallel(const DistributedOptions& options, const std::string& job);

}  // namespace lrf
