#include "lrf/core/openmp_wait.h"

#include <cstdlib>

#include <unistd.h>

namespace lrf {

void restart_with_passive_openmp_wait(char** argv) {
  if (std::getenv("OMP_WAIT_POLICY") != nullptr || std::getenv("GOMP_SPINCOUNT") != nullptr) return;
  if (setenv("OMP_WAIT_POLICY", "passive", 1) != 0) return;
  execv("/proc/self/exe", argv);
  // Not restarted: this process keeps libgomp's default; child processes see the variable.
}

std::string openmp_wait_policy() {
  const char* policy = std::getenv("OMP_WAIT_POLICY");
  const char* spins = std::getenv("GOMP_SPINCOUNT");
  if (policy != nullptr) return policy;
  if (spins != nullptr) return std::string("GOMP_SPINCOUNT=") + spins;
  return "default";
}

}  // namespace lrf
