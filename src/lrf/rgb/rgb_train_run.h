#pragma once
// Training an RGB Gaussian field into an output folder: `lrf train --space rgb`, and the image-space rows
// of lrf compare and lrf pipeline (rgb, rgb-mip, and rgb/8, rgb/8-mip: the paper's 3DGS/8 and
// Mip-Splatting/8, trained on the views reduced 8x so that they see as many pixels as a latent field).
// One job for all of them, so that every RGB folder records the same option names and `lrf train --resume`
// continues any of them.
//
// OUT/config.json describes the scene at its full resolution whatever `factor` the views were reduced by
// for training, so that lrf render / eval / serve work at full resolution; "options" holds the options
// below under the names of lrf train's flags (recorded_rgb_options reads them back).
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "lrf/points/initial_points.h"
#include "lrf/scene/scene.h"
#include "lrf/splat/run/fit_options.h"

namespace lrf {

// What an RGB field's fit sets beyond a Gaussian field's (also lrf train's request, field_kinds/).
struct RgbFitSettings {
  bool mip = false;  // Mip-Splatting's 3D smoothing and 2D Mip filters
  bool white_background = false;
  int coarse_factor = 1;      // > 1 trains the first steps on reduced views (TrainerOptions::coarse_factor)
  int64_t coarse_until = -1;  // the coarse phase's last step; -1: where densification ends
};

// A Gaussian field's fit (scene, length, densification, seed, points, ...) with what an RGB field adds.
struct RgbTrainOptions : splat::GaussianFitOptions, RgbFitSettings {
  // Training views reduced by this factor in width and height (area-averaged, intrinsics scaled): the
  // compare rows' /8. Their size must be a multiple of it (crop_to_multiple_of_8 makes 2, 4 and 8 exact).
  int factor = 1;
  std::string task = "train";  // the progress line's label
};

struct RgbTrainResult {
  int64_t steps = 0, gaussians = 0;
  double seconds = 0;
};

// Throws lrf::UsageError for bad options, lrf::Error naming the file for a bad scene or output folder.
RgbTrainResult train_rgb_field(const RgbTrainOptions& options);

// The options OUT's RGB run was started with (for --resume), from its config.json: the scene settings
// from the keys that reload the scene, the rest from "options" (absent ones, in folders written before
// they existed, at their defaults). `config` is OUT/config.json as read. Throws lrf::Error naming config.json
// for a folder that holds no RGB run.
RgbTrainOptions recorded_rgb_options(const std::string& out, const nlohmann::json& config);

}  // namespace lrf
