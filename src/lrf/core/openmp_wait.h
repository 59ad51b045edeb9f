#pragma once
// How OpenMP's idle worker threads wait. libgomp's default spins for a long while before sleeping, which
// suits a machine of one's own; on a shared machine a worker whose partner thread was descheduled spins
// through its time slice at every barrier. Measured on the 2-core EPYC with one core kept busy by another
// session's job (a 1500-step latent fit of fern, docs/speed.md): 334 s at 2 threads with the default, 46 s
// with passive waiting (1 thread: 43 s); on the quiet machine 26 s and 25 s. libgomp reads its settings once,
// when it is loaded (before main), so the policy is set in the environment and the program started again.
#include <string>

namespace lrf {

// When neither OMP_WAIT_POLICY nor GOMP_SPINCOUNT is set: sets OMP_WAIT_POLICY=passive and re-executes
// this program (/proc/self/exe) with the same arguments. Returns if either was set already (the user's
// choice stands), or if the re-execution failed (the program goes on with libgomp's default).
void restart_with_passive_openmp_wait(char** argv);

// The wait policy this process runs with, as the environment set it ("default" when neither variable is
// set), for the record of a run.
std::string openmp_wait_policy();

}  // namespace lrf
