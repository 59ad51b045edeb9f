#pragma once
// What every Gaussian field's fit shares, whatever its Gaussians carry (RGB colours, latents, features): a
// scene fit's settings (scene_fit_options.h) and the Gaussians' own (SH degree, densification, sparse
// Adam). RGB and latent fields extend it; one function turns it into the
// trainer's options and one writes its part of config.json's "options".
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "lrf/splat/run/scene_fit_options.h"
#include "lrf/splat/train/densify.h"

namespace lrf::splat {

struct TrainerOptions;  // splat/train/trainer.h

struct GaussianFitOptions : SceneFitOptions {
  int sh_degree = 3;
  int64_t max_gaussians = 0;  // 0 = no cap
  double densify_grad = DensifyOptions{}.grad_threshold;
  bool sparse_adam = false;
};

// The trainer's length, SH degree, seed, sparse Adam and densification (schedule, cap, threshold).
TrainerOptions trainer_options(const GaussianFitOptions& options);

// The shared part of config.json's "options", under the names of lrf train's flags: scene, out, images,
// downscale, test_every, train_views, iters, sh_degree, seed, max_gaussians, densify_grad, checkpoint_every,
// sparse_adam, preset, resume, force.
nlohmann::json fit_options_json(const GaussianFitOptions& options);

}  // namespace lrf::splat
