// lrf launch: start N ranks of a data-parallel lrf command on this host (like torchrun).
#include <memory>

#include "command.h"
#include "lrf/distributed/local_launcher.h"

namespace {

lrf::cli::CommandRegistration reg(48, [](CLI::App& root) {
  auto* cmd = root.add_subcommand(
      "launch",
      "Start N ranks of a data-parallel command on this host, like torchrun: lrf launch -n 2 -- lrf finetune-encoder "
      "... Each rank gets RANK, LOCAL_RANK, WORLD_SIZE, MASTER_ADDR=127.0.0.1 and MASTER_PORT (a free port unless "
      "MASTER_PORT is set); lrf commands without --threads get cores / N threads each. Ctrl-C is forwarded to every "
      "rank (twice: killed). When a rank fails the others stop on their own, naming it; the exit status is the first "
      "failed rank's. On a Slurm cluster use srun instead (see docs/distributed.md)");
  auto o = std::make_shared<lrf::LaunchOptions>();
  cmd->add_option("-n,--nproc", o->ranks, "Number of ranks to start")->required();
  cmd->add_option("--master-port", o->master_port, "Rendezvous port (0: $MASTER_PORT, else a free port)")
      ->capture_default_str();
  cmd->add_option("--threads-per-rank", o->threads_per_rank,
                  "Threads of each lrf rank that does not set --threads itself (0: cores / N)")
      ->capture_default_str();
  cmd->add_option("--grace", o->grace_seconds,
                  "Seconds the other ranks get to stop on their own after one failed, before they are terminated")
      ->capture_default_str();
  cmd->add_option("command", o->command, "The command to run on every rank, after --")->required();
  cmd->positionals_at_end();
  lrf::cli::on_run(cmd, [o] { return lrf::launch_local(*o); });
});

}  // namespace
