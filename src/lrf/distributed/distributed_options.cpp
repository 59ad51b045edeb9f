#include "lrf/distributed/distributed_options.h"

#include <cstdlib>
#include <optional>

#include "lrf/core/error.h"

namespace lrf {
namespace {

// The first of `names` that is set, as an integer; throws naming the variable if it is not one.
std::optional<long> env_integer(std::initializer_list<const char*> names) {
  for (const char* name : names) {
    const char* value = std::getenv(name);
    if (!value || !*value) continue;
    char* end = nullptr;
    const long v = std::strtol(value, &end, 10);
    if (*end != '\0') fail(std::string("environment variable ") + name + "='" + value + "' is not an integer");
    return v;
  }
  return std::nullopt;
}

}  // namespace

DistributedOptions resolve_distributed_options(const DistributedOptions& flags) {
  DistributedOptions o = flags;
  if (o.world_size < 0) o.world_size = static_cast<int>(env_integer({"WORLD_SIZE", "SLURM_NTASKS"}).value_or(1));
  if (o.rank < 0) o.rank = static_cast<int>(env_integer({"RANK", "SLURM_PROCID"}).value_or(0));
  if (o.local_rank < 0) o.local_rank = static_cast<int>(env_integer({"LOCAL_RANK", "SLURM_LOCALID"}).value_or(0));
  if (o.master_addr.empty()) {
    const char* addr = std::getenv("MASTER_ADDR");
    o.master_addr = addr && *addr ? addr : "127.0.0.1";
  }
  if (o.master_port == 0) o.master_port = static_cast<int>(env_integer({"MASTER_PORT"}).value_or(29500));
  if (o.world_size < 1) fail("world size " + std::to_string(o.world_size) + " (--world-size / WORLD_SIZE) must be at least 1");
  if (o.rank < 0 || o.rank >= o.world_size) {
    fail("rank " + std::to_string(o.rank) + " (--rank / RANK) is outside 0.." + std::to_string(o.world_size - 1) +
         " for a world size of " + std::to_string(o.world_size));
  }
  if (o.master_port < 1 || o.master_port > 65535) {
    fail("master port " + std::to_string(o.master_port) + " (--master-port / MASTER_PORT) is not a TCP port");
  }
  if (!(o.timeout_seconds > 0)) fail_usage("--dist-timeout must be positive");
  return o;
}

}  // namespace lrf
