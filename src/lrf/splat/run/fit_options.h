#pragma once
// What every Gaussian field's fit shares, whatever its Gaussians carry (RGB colours, latents, features):
// the scene and the output folder, the length, densification and seed, the checkpoints, where the initial
// points come from and the preset. RGB and latent fields extend it; one function turns it into the
// trainer's options and one writes its part of config.json's "options".
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "lrf/points/initial_points.h"
#include "lrf/scene/scene.h"
#include "lrf/splat/train/densify.h"

namespace lrf::splat {

struct TrainerOptions;  // splat/train/trainer.h

struct GaussianFitOptions {
  std::string scene, out;
  SceneOptions scene_options;
  int64_t iters = 30000;
  int sh_degree = 3;
  uint64_t seed = 0;
  int64_t max_gaussians = 0;  // 0 = no cap
  double densify_grad = DensifyOptions{}.grad_threshold;
  int64_t checkpoint_every = 1000;
  bool sparse_adam = false;
  InitPointsOptions init_points;   // where the initial Gaussians come from (SfM, triangulated, random, a file)
  std::string preset = "default";  // the --preset the options came from, recorded for --resume
  bool resume = false, force = false;
};

// The trainer's length, SH degree, seed, sparse Adam and densification (schedule, cap, threshold).
TrainerOptions trainer_options(const GaussianFitOptions& options);

// The shared part of config.json's "options", under the names of lrf train's flags: scene, out, images,
// downscale, test_every, train_views, iters, sh_degree, seed, max_gaussians, densify_grad, checkpoint_every,
// sparse_adam, preset, resume, force.
nlohmann::json fit_options_json(const GaussianFitOptions& options);

}  // namespace lrf::splat
