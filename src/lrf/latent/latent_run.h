#pragma once
// Stage II runs on disk: training a latent field into an output folder, and reopening one to render
// latents, decode them and score the decoded test views.
//
// OUT/config.json records the scene, resolution, autoencoder (and encoder override), the latent range and
// the training options; OUT/point_cloud.ply holds the field with C = latent channels. A feature field
// (--feature-dim D) holds D channels there, records "feature_dim": D, and keeps its lift in
// OUT/lift.safetensors.
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "lrf/autoencoder/autoencoder.h"
#include "lrf/autoencoder/latent_source.h"
#include "lrf/feature/feature_lift.h"
#include "lrf/latent/latent_normalization.h"
#include "lrf/points/initial_points.h"
#include "lrf/scene/scene.h"
#include "lrf/splat/gaussians.h"
#include "lrf/splat/render_field.h"
#include "lrf/splat/run/fit_options.h"
#include "lrf/splat/train/densify.h"

namespace lrf {

// Default SH degree of latent fields: degree 1 (4 coefficients per channel). With 32 channels each degree
// multiplies the feature memory and optimizer work (degree 3: 16x the view-independent field). Degree 1
// over degree 0 on held-out views: +0.22 dB on fern's validation split, +0.48 dB on ngp-fox, with
// about 3x the storage; after decoder-aware refinement the two are level (docs/results.md, "SH degree of
// latent fields").
constexpr int kDefaultLatentShDegree = 1;
// LatentTrainOptions::feature_dim asking for default_feature_dim(latent channels).
constexpr int kHalfLatentChannels = -1;

// A Gaussian field's fit with what a latent field adds. Its scene options' image folder, downscale, test
// split and few-shot training views are read; the views are always centre-cropped to multiples of 8, and a
// test list and a forced format are not read for latent fields yet.
// What a latent field's fit sets beyond a Gaussian field's and its latents (also lrf train's request).
struct LatentFitSettings {
  std::string init = "latents";
  // > 0: the field carries 3 more channels fitted (times this weight) to the training images at latent
  // resolution, and drops them when written (prepare_latent_training's rgb_guide).
  double rgb_guide = 0;
  // > 0: a feature field (the feature-gs baseline, src/lrf/feature/): the Gaussians carry this many
  // features, lifted to the latent channels by a 1x1 convolution trained with them. 0: a latent field.
  // kHalfLatentChannels: Feature 3DGS's default, half the autoencoder's latent channels.
  int feature_dim = 0;
};

struct LatentTrainOptions : splat::GaussianFitOptions, LatentSource, LatentFitSettings {
  LatentTrainOptions() { sh_degree = kDefaultLatentShDegree; }
  // A run shorter than 7000 steps moves its means and SH faster (splat::LearningRates::for_short_run);
  // false keeps Inria's rates.
  bool short_run_rates = true;
};

struct LatentTrainResult {
  int64_t steps = 0, gaussians = 0;
  double seconds = 0, encode_seconds = 0;
};

LatentTrainResult train_latent_field(const LatentTrainOptions& options);

struct LatentRun {
  std::string out;
  nlohmann::json config;
  Scene scene;  // at the training resolution, cropped to multiples of 8
  splat::Gaussians field;
  splat::FieldRenderOptions render;
  LatentRange range;
  std::string autoencoder, encoder;
  std::string decoder;  // the decoder a refined field was fitted through ("" = the autoencoder's)
  FeatureLift lift;     // a feature field's 1x1 convolution (undefined for a latent field)
};

// Opens OUT; throws lrf::Error naming the file when it is not a finished latent run, or when the scene
// or the autoencoder's files changed since training (the field would not match them).
LatentRun open_latent_run(const std::string& out);

// Renders view i's normalised latent [C, h, w] (latent resolution of the training camera); a feature
// field's rendered features are lifted to the latent channels first.
torch::Tensor render_latent(const LatentRun& run, int view);
// The same for any camera at latent resolution (latent_camera of an image camera).
torch::Tensor render_latent_at(const LatentRun& run, const Camera& latent_camera);

struct LatentEvalOptions {
  std::string decoder;        // decoder override (Stage III) ("" = the run's own: see LatentRun::decoder)
  std::string lpips_weights;  // "" = LPIPS not computed ("lpips": null with the reason)
  bool write_images = true;   // <output_dir>/eval/<name>.png decoded test views
  std::string output_dir;     // where metrics.json and eval/ go ("" = the run folder OUT)
};

// Scores the decoded test views against the real images (at 8x the latent size): PSNR, SSIM, LPIPS, plus
// the autoencoder's round-trip PSNR on the same views (the ceiling) and the latent-space PSNR of the
// rendered latents against the encoded test views; writes metrics.json (in options.output_dir, default OUT)
// and returns it.
nlohmann::json evaluate_latent_run(const std::string& out, const LatentEvalOptions& options);

}  // namespace lrf
