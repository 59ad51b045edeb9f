#pragma once
// Seeds of a run's random streams. Every random choice a training step makes (view order, densification's
// splits, Stage I's pairs and posterior sample, Stage III's crops, the refinement's windows and jitter, a
// NeRF's rays and samples) comes from a generator seeded by (run seed, stream, index) alone: a run resumed
// from a checkpoint draws what the uninterrupted run drew, whatever the thread count, and no two streams
// share a sequence. The index is the step (or epoch) the draw belongs to.
#include <cstdint>

namespace lrf {

enum class SeedStream : uint64_t {
  view_order = 1,  // the Gaussian trainer's shuffled views, per epoch
  densify_split = 2,
  refine_windows = 3,
  refine_jitter = 4,
  nerf_rays = 5,
  stage1_pairs = 6,
  stage1_posterior = 7,  // the KL-VAE's posterior sample
  stage3_crops = 8,
};

uint64_t stream_seed(uint64_t run_seed, SeedStream stream, uint64_t index);

}  // namespace lrf
