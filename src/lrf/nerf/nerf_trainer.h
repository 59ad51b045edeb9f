#pragma once
// Training a latent NeRF: each step draws a batch of rays uniformly from every training pixel (with
// replacement), places jittered coarse + fine samples, and takes an Adam step on the mean squared error
// of the rendered normalised latents (NeRF's loss). Adam as Instant-NGP sets it (β = 0.9, 0.99, ε = 1e-15),
// with a learning rate decaying log-linearly from `lr` to `lr_final` over the run; grid entries that no
// sample touched in a step are left alone (their moments too), so rarely seen cells are not dragged by
// stale momentum.
//
// The randomness of step k comes from a generator seeded by (seed, k) alone, so a run resumed from a
// checkpoint (field, Adam moments, step) continues exactly as the uninterrupted run would have.
#include <cstdint>
#include <string>
#include <vector>

#include <ATen/Tensor.h>

#include "lrf/nerf/nerf_field.h"
#include "lrf/nerf/nerf_render.h"
#include "lrf/optim/param_adam.h"
#include "lrf/scene/camera.h"

namespace lrf::nerf {

struct NerfTrainOptions {
  int64_t iterations = 20000;
  int rays_per_step = 1024;
  double lr = 1e-2, lr_final = 1e-3;
  uint64_t seed = 0;
  void check() const;  // throws lrf::Error naming the bad setting
};

// Every training pixel as a ray with its target latent.
struct NerfTrainingRays {
  std::vector<double> origins, directions;  // [n, 3]
  at::Tensor targets;                       // [n, C] float32 (normalised latents)
  int64_t count() const { return targets.defined() ? targets.size(0) : 0; }
};

// cameras[k] sees latents[k] [C, h, w] (its resolution must be the camera's).
NerfTrainingRays training_rays(const std::vector<Camera>& cameras, const std::vector<at::Tensor>& latents);

struct NerfStepResult {
  int64_t step = 0;  // 1-based count of steps done
  double loss = 0, psnr = 0;  // on this step's batch; PSNR of normalised latents (peak 1)
  RenderTimings timings;      // sampling, forward, backward
  double optimizer_seconds = 0;
};

class NerfTrainer {
 public:
  NerfTrainer(NerfField field, NerfTrainingRays rays, const NerfTrainOptions& options);

  NerfStepResult step();
  bool done() const { return steps_done() >= options_.iterations; }
  int64_t steps_done() const { return adam_.steps(); }
  const NerfField& field() const { return field_; }
  const NerfTrainOptions& options() const { return options_; }
  double learning_rate(int64_t step) const;

  // Field, Adam moments and step count (ParamAdam's checkpoint, with the field's spec), written atomically;
  // load refuses a checkpoint of another layout.
  void save_checkpoint(const std::string& path) const;
  void load_checkpoint(const std::string& path);

 private:
  NerfField field_;
  ParamAdam adam_;  // over field_'s tensors, updated in place; its step count is the trainer's
  NerfTrainingRays rays_;
  NerfTrainOptions options_;
};

}  // namespace lrf::nerf
