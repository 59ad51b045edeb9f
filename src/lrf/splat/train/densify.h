#pragma once
// Adaptive density control of 3DGS: statistics of the screen-space gradient, clone / split / prune,
// opacity reset, all keeping the optimizer's moments row-aligned with the parameters.
#include <cstdint>

#include <torch/types.h>

#include "lrf/splat/gaussians.h"
#include "lrf/splat/train/optimizer.h"

namespace lrf::splat {

// When things happen, in training steps (1-based, as in the Inria code).
struct DensifySchedule {
  int64_t from = 500, until = 15000, interval = 100;
  int64_t opacity_reset_every = 3000;
  int64_t sh_degree_every = 1000;
  // Inria's schedule, with densification ending at half the run (Inria: step 15000 of 30000; at most
  // 15000). Runs shorter than 7000 steps (Inria's short run) compress the other periods by iters / 7000,
  // densifying at most every 10 steps. A first version compressed everything by iters / 30000: at
  // 7000 steps that meant 147 densifications instead of 30 and a field 5x larger and slower to train.
  static DensifySchedule for_iterations(int64_t iterations);
  bool densify_at(int64_t step) const { return step > from && step < until && step % interval == 0; }
  bool reset_opacity_at(int64_t step) const { return step < until && step % opacity_reset_every == 0; }
};

struct DensifyOptions {
  double grad_threshold = 2e-4;  // mean |d loss / d means2d| (NDC units)
  double percent_dense = 0.01;   // clone if the largest scale <= this x extent, else split
  double min_opacity = 0.005;
  double max_screen_radius = 20;  // pixels, only after the first opacity reset
  double max_world_scale = 0.1;   // x extent
  int64_t max_gaussians = 0;      // 0 = no cap
};

struct DensifyStats {
  int64_t cloned = 0, split = 0, pruned = 0, before = 0, after = 0;
};

class Densifier {
 public:
  Densifier() = default;
  explicit Densifier(int64_t n) { resize(n); }
  // Adds one view's statistics: |grad of means2d| and max radius of the visible (radii > 0) Gaussians.
  void accumulate(const torch::Tensor& means2d_grad, const torch::Tensor& radii);
  // Clone / split the Gaussians whose mean gradient exceeds the threshold, then prune. Resets the
  // statistics. `seed` drives the split samples. Pruning judges the unfiltered opacity (as Mip-Splatting
  // does).
  DensifyStats densify_and_prune(Gaussians& g, GaussianAdam& adam, double extent, bool prune_screen_size,
                                 uint64_t seed, const DensifyOptions& options);
  // Opacity reset: rendered opacity = min(opacity, 0.01); opacity moments zeroed. With the Mip 3D
  // filter, its opacity factor [N,1] caps the rendered (filtered) opacity, as Mip-Splatting does.
  static void reset_opacity(Gaussians& g, GaussianAdam& adam, const torch::Tensor& opacity_filter_coef = {});

  torch::Tensor grad_accum, denom, max_radii;  // [N] float32
  void resize(int64_t n);
};

// Puts the rows in Z-order of their means (spatial_order.h), the optimizer's moments with them. After a
// densification the clones and split children sit at the end, far from their neighbours in memory.
void sort_spatially(Gaussians& g, GaussianAdam& adam);

// Rotation matrices [N, 3, 3] of quaternions [N, 4] (w, x, y, z; normalised here).
torch::Tensor quaternion_to_matrix(const torch::Tensor& quats);

}  // namespace lrf::splat
