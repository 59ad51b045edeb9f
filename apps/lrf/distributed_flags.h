#pragma once
// The data-parallel flags of finetune-encoder and finetune-decoder. Each defaults to its torchrun / Slurm
// environment variable; `lrf launch` and `srun` set those, so the flags are rarely needed by hand.
#include <CLI/CLI.hpp>

#include "lrf/core/log.h"
#include "lrf/distributed/distributed_options.h"

namespace lrf::cli {

inline void add_distributed_flags(CLI::App* cmd, DistributedOptions* o) {
  const std::string g = "Data parallel";
  cmd->add_option("--rank", o->rank, "This process's rank (default: $RANK, $SLURM_PROCID, else 0)")->group(g);
  cmd->add_option("--world-size", o->world_size,
                  "Number of ranks; the global batch is split over them (default: $WORLD_SIZE, $SLURM_NTASKS, else 1)")
      ->group(g);
  cmd->add_option("--local-rank", o->local_rank, "Rank on this host (default: $LOCAL_RANK, $SLURM_LOCALID, else 0)")
      ->group(g);
  cmd->add_option("--master-addr", o->master_addr, "Host of rank 0 (default: $MASTER_ADDR, else 127.0.0.1)")->group(g);
  cmd->add_option("--master-port", o->master_port, "Rendezvous port on rank 0's host (default: $MASTER_PORT, else 29500)")
      ->group(g);
  cmd->add_option("--dist-timeout", o->timeout_seconds,
                  "Seconds a rank waits for the others (start-up, each all-reduce) before stopping with an error "
                  "naming the rank that is missing")
      ->capture_default_str()
      ->group(g);
}

// Resolves the flags against the environment; ranks other than 0 print only warnings and errors.
inline DistributedOptions resolve_distributed_flags(const DistributedOptions& flags) {
  DistributedOptions o = resolve_distributed_options(flags);
  if (o.rank != 0 && log_mode() == LogMode::normal) set_log_mode(LogMode::quiet);
  return o;
}

}  // namespace lrf::cli
