#pragma once
// Stage II: training a latent field (or a feature field lifted to the latents) into an output folder
// (latent_run.h says what the folder holds and reopens it).
#include <cstdint>
#include <string>

#include "lrf/autoencoder/latent_source.h"
#include "lrf/splat/run/fit_options.h"

namespace lrf {

// Default SH degree of latent fields: degree 1 (4 coefficients per channel). With 32 channels each degree
// multiplies the feature memory and optimizer work (degree 3: 16x the view-independent field). Degree 1
// over degree 0 on held-out views: +0.22 dB on fern's validation split, +0.48 dB on ngp-fox, with
// about 3x the storage; after decoder-aware refinement the two are level (docs/results.md, "SH degree of
// latent fields").
constexpr int kDefaultLatentShDegree = 1;
// LatentTrainOptions::feature_dim asking for default_feature_dim(latent channels).
constexpr int kHalfLatentChannels = -1;

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

// A Gaussian field's fit with what a latent field adds. Its scene options' image folder, downscale, test
// split and few-shot training views are read; the views are always centre-cropped to multiples of 8, and a
// test list and a forced format are not read for latent fields yet.
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

}  // namespace lrf
