#pragma once
// The image-space baselines that latent fields are compared with: RGB 3D Gaussian splatting trained on
// the views (cropped to multiples of 8) at full resolution, or downscaled by the autoencoder's factor 8
// so that they see as many pixels as a latent field (the paper's 3DGS/8 and, with Mip-Splatting's
// filters, Mip-Splatting/8). Every run's config describes the full-resolution scene, so `lrf render` /
// `eval` and the scores below work at full resolution whatever the training resolution.
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "lrf/points/initial_points.h"
#include "lrf/scene/scene.h"

namespace lrf {

struct RgbBaselineOptions {
  std::string scene;      // scene folder
  SceneOptions scene_options;
  std::string out;
  int factor = 8;         // training views downscaled by this (1 = full resolution)
  int64_t iters = 7000;
  bool mip = false;
  uint64_t seed = 0;
  bool resume = false;
  InitPointsOptions init_points;  // where the initial Gaussians come from
};

void train_rgb_baseline(const RgbBaselineOptions& options);

}  // namespace lrf
