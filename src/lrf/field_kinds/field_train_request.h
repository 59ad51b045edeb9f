#pragma once
// What `lrf train` asks a kind of field to fit: the command line's settings for every kind in one record,
// bound to its flags once. Each kind takes its own settings and refuses another kind's when they were
// given (field_type.h: FieldType::train and FieldType::resume).
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "lrf/autoencoder/latent_source.h"
#include "lrf/latent/latent_run.h"
#include "lrf/latent/latent_train_run.h"
#include "lrf/nerf/nerf_run.h"
#include "lrf/nerf/nerf_train_run.h"
#include "lrf/points/initial_points.h"
#include "lrf/presets/presets.h"
#include "lrf/rgb/rgb_train_run.h"
#include "lrf/scene/scene.h"
#include "lrf/splat/run/fit_options.h"

namespace lrf {

// The fit every Gaussian field shares (scene, out, steps, SH degree, seed, densification, checkpoints,
// initial points, preset), with every kind's own settings beside it.
// Each kind's own settings are the parts its job's options share with the request: RgbFitSettings
// (rgb), LatentSource and LatentFitSettings (latent; latent-nerf takes LatentSource), NerfFitSettings
// (latent-nerf).
struct FieldTrainRequest : splat::GaussianFitOptions,
                           RgbFitSettings,
                           LatentSource,
                           LatentFitSettings,
                           nerf::NerfFitSettings {
  std::string space = "rgb";
  bool iters_set = false;
  bool sh_degree_set = false;
  bool inria_rates = false;      // latent: no faster means and SH in runs under 7000 steps
  bool nerf_option_set = false;  // one of NerfFitSettings was given
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
