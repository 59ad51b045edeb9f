#pragma once
// Latent NeRF runs on disk (lrf train --space latent-nerf, lrf compare's latent-nerf row; training one:
// nerf_train_run.h): a NeRF fitted
// to the same normalised latents as the latent Gaussian field (the encoded training views, cached, with
// the per-channel training range), rendered at latent resolution and decoded the same way.
//
// OUT/config.json records the command, the scene, the autoencoder, the latent range, the NeRF's spec and
// its training options ("result" is added when the run ends); OUT/field.safetensors holds the field
// (refreshed at every checkpoint, so an unfinished run can be rendered); OUT/checkpoint.safetensors the
// field, Adam's moments and the step; OUT/train_log.csv the loss every 10 steps.
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>
#include <torch/types.h>

#include "lrf/latent/latent_normalization.h"
#include "lrf/latent/latent_run.h"
#include "lrf/nerf/nerf_field.h"
#include "lrf/scene/scene.h"

namespace lrf::nerf {

std::string nerf_field_path(const std::string& out);
std::string nerf_checkpoint_path(const std::string& out);
// It trained to its end: config.json has its "result" and the field exists.
bool nerf_run_finished(const std::string& out);

struct NerfRun {
  std::string out;
  nlohmann::json config;
  Scene scene;  // at the training resolution, cropped to multiples of 8
  NerfField field;
  LatentRange range;
  std::string autoencoder, encoder;
};

// Opens OUT; throws lrf::Error naming the file when it is not a latent NeRF run with a field, or when the
// scene or the autoencoder's files changed since training.
NerfRun open_nerf_run(const std::string& out);

// View i's normalised latent [C, h/8, w/8], rendered at its latent camera.
torch::Tensor render_nerf_latent(const NerfRun& run, int view);

// As evaluate_latent_run: decoded test views scored, metrics.json written (with training time, memory,
// storage and render / decode speed) and returned.
nlohmann::json evaluate_nerf_run(const std::string& out, const LatentEvalOptions& options);

}  // namespace lrf::nerf
