#pragma once
// Where a process stands in a data-parallel job, configured the way torchrun and Slurm users expect:
// RANK, WORLD_SIZE, LOCAL_RANK, MASTER_ADDR and MASTER_PORT from the environment (Slurm's SLURM_PROCID,
// SLURM_NTASKS and SLURM_LOCALID when those are absent, so a bare `srun lrf ...` works), each overridden
// by the matching command-line flag. Without any of them a job is one process (world size 1).
#include <string>

namespace lrf {

struct DistributedOptions {
  int rank = -1, world_size = -1, local_rank = -1;  // -1: from the environment
  std::string master_addr;                          // "": from the environment, else 127.0.0.1
  int master_port = 0;                              // 0: from the environment, else 29500
  // A collective that waits longer than this for another rank fails (a hung rank); rendezvous too.
  double timeout_seconds = 300;
};

// The flags filled in from the environment and checked (0 <= rank < world_size, a port in range);
// throws lrf::Error naming the variable or flag that is wrong.
DistributedOptions resolve_distributed_options(const DistributedOptions& flags);

}  // namespace lrf
