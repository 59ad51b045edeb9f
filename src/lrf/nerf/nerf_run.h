#pragma once
// Latent NeRF runs on disk (lrf train --space latent-nerf, lrf compare's latent-nerf row): a NeRF fitted
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

#include "lrf/autoencoder/latent_source.h"
#include "lrf/latent/latent_normalization.h"
#include "lrf/latent/latent_run.h"
#include "lrf/nerf/nerf_field.h"
#include "lrf/splat/run/scene_fit_options.h"
#include "lrf/scene/scene.h"

namespace lrf::nerf {

// Steps of a latent NeRF unless told otherwise: about 50 minutes at 1 thread on fern at images_8 (63×47
// rays per view, 17 views) on the 2-core development machine, within the hour the efficiency table allows it.
constexpr int64_t kDefaultNerfIters = 10000;

// scene_options (SceneFitOptions): the image folder, downscale, test split and few-shot training views
// (train_views: K evenly spaced training views; 0 = all), as for latent Gaussian fields: cropped to multiples
// of 8, no test list. init_points: the points that bound the scene (SfM, triangulated, a file).
// The field's shape and sampling, fixed when a run starts (also lrf train's request).
struct NerfFitSettings {
  int rays = 1024;       // rays per step
  int samples = 32;      // coarse samples per ray, and as many fine ones
  int log2_table = 17;   // hash table entries per level: 2^log2_table
};

struct LatentNerfOptions : SceneFitOptions, LatentSource, NerfFitSettings {
  LatentNerfOptions() { iters = kDefaultNerfIters; }
};

struct LatentNerfResult {
  int64_t steps = 0, parameters = 0;
  double seconds = 0, encode_seconds = 0, final_loss = 0;
};

LatentNerfResult train_latent_nerf(const LatentNerfOptions& options);

// The options the run in OUT was started with (for --resume); throws lrf::Error naming config.json.
LatentNerfOptions recorded_nerf_options(const std::string& out);

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
