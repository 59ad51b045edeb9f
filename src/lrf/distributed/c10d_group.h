#pragma once
// Inside src/lrf/distributed only: the c10d objects behind a DataParallelGroup. Gloo's process group is
// declared only with USE_C10D_GLOO (libtorch was built with it).
#ifndef USE_C10D_GLOO
#define USE_C10D_GLOO 1
#endif
#include <atomic>
#include <memory>
#include <thread>

#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>

#include "lrf/distributed/data_parallel_group.h"

namespace lrf {

struct DataParallelGroup::Impl {
  DistributedOptions options;
  std::string job;
  c10::intrusive_ptr<c10d::TCPStore> store;       // the collectives' rendezvous and the failure notes
  c10::intrusive_ptr<c10d::ProcessGroupGloo> group;
  c10::intrusive_ptr<c10d::TCPStore> pulse_store;  // a connection of the heartbeat thread's own
  std::thread pulse;
  // Shared with the heartbeat thread, which may outlive this object (detached after a failure).
  std::shared_ptr<std::atomic<bool>> stop = std::make_shared<std::atomic<bool>>(false);
  bool failed = false;  // a rank stopped: the heartbeat may hang on a store that no longer answers
};

}  // namespace lrf
