#pragma once
// What `lrf train` asks a kind of field to fit: the command line's settings for every kind in one record,
// bound to its flags once. Each kind takes its own settings and refuses another kind's when they were
// given (field_type.h: FieldType::train and FieldType::resume).
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "lrf/points/initial_points.h"
#include "lrf/presets/presets.h"
#include "lrf/scene/scene.h"
#include "lrf/splat/run/fit_options.h"

namespace lrf {

// The fit every Gaussian field shares (scene, out, steps, SH degree, seed, densification, checkpoints,
// initial points, preset), with every kind's own settings beside it.
struct FieldTrainRequest : splat::GaussianFitOptions {
  std::string space = "rgb";
  bool iters_set = false;
  bool sh_degree_set = false;
  bool mip = false;
  bool inria_rates = false;  // latent: no faster means and SH in runs under 7000 steps
  bool white_background = false;
  int coarse_factor = 1;       // rgb: > 1 trains the first steps on reduced views
  int64_t coarse_until = -1;   // the coarse phase's last step; -1: where densification ends
  // latent and latent-nerf: the autoencoder and its latents
  std::string autoencoder = "taef2";
  std::string encoder;
  std::string init = "latents";
  double rgb_guide = 0;
  int feature_dim = 0;  // > 0: a feature field (the feature-gs baseline)
  std::string cache_dir;
  // latent-nerf
  int rays = 1024, samples = 32, hash_log2 = 17;
  bool nerf_option_set = false;  // one of the three above was given
};

// `lrf train OUT --resume`: the run continues with its recorded settings; of `given`, only the step count
// and checkpoint interval (when given on the command line) and where caches live may change.
struct ResumeRequest {
  FieldTrainRequest given;
  bool iters_given = false, checkpoint_given = false, preset_given = false;
};

// The initial points' options, with the points cached beside the encoded views unless told otherwise;
// throws lrf::UsageError for an unknown mode.
InitPointsOptions train_points(const FieldTrainRequest& request);

// Each kind's own settings, refused (lrf::UsageError naming them) when given for another kind of field.
void refuse_latent_settings(const FieldTrainRequest& request);  // --rgb-guide, --inria-rates
void refuse_rgb_settings(const FieldTrainRequest& request);     // --coarse-factor, --coarse-until
void refuse_nerf_settings(const FieldTrainRequest& request);    // --rays, --samples, --hash-log2

// --resume keeps the preset a run started with: asking for another is refused, not silently ignored.
void require_recorded_preset(const ResumeRequest& request, const std::string& recorded, const std::string& config_path);

// The scene a resumed field trains on: where its config.json records it (absolute, else relative to the
// run folder, so that a project folder moved as a whole resumes) or, when it is at neither place, the scene
// this command line names (`lrf train NEW_PLACE -o OUT --resume` after the scene alone moved), once it is
// seen to have the recorded numbers of training and test views. Warns when the recorded scene is used in
// place of another one named.
std::string resumed_scene_root(const FieldTrainRequest& given, const nlohmann::json& config, const std::string& path,
                               const SceneOptions& scene_options, const std::string& recorded_scene);

}  // namespace lrf
