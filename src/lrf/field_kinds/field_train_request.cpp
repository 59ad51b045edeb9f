#include "lrf/field_kinds/field_train_request.h"

#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/scene/run_scene_location.h"

namespace lrf {

InitPointsOptions train_points(const FieldTrainRequest& request) {
  InitPointsOptions points = request.init_points;
  if (points.cache_dir.empty()) points.cache_dir = request.cache_dir;  // triangulated points live beside the latents
  check_init_points_mode(points.mode);
  return points;
}

void refuse_latent_settings(const FieldTrainRequest& o) {
  if (o.rgb_guide != 0) fail_usage("--rgb-guide applies to --space latent");
  if (o.inria_rates) fail_usage("--inria-rates applies to --space latent");
}

void refuse_rgb_settings(const FieldTrainRequest& o) {
  if (o.coarse_factor != 1 || o.coarse_until != -1) fail_usage("--coarse-factor and --coarse-until apply to --space rgb");
}

void refuse_nerf_settings(const FieldTrainRequest& o) {
  if (o.nerf_option_set) fail_usage("--rays, --samples and --hash-log2 apply to --space latent-nerf");
}

void require_recorded_preset(const ResumeRequest& request, const std::string& recorded, const std::string& config_path) {
  const std::string& given = request.given.preset;
  if (!request.preset_given || given == recorded) return;
  fail_usage("--preset " + given + ": this run was started with --preset " + recorded + " (" + config_path +
             ") and --resume keeps its recorded settings; drop --preset, or start a new run in another folder");
}

std::string resumed_scene_root(const FieldTrainRequest& given, const nlohmann::json& config, const std::string& path,
                               const SceneOptions& scene_options, const std::string& recorded_scene) {
  const std::string named = given.scene == given.out ? "" : given.scene;
  std::string root;
  try {
    root = resumed_run_scene_root(config, path, named, scene_options);
  } catch (const Error& e) {
    if (!named.empty()) throw;
    throw Error(std::string(e.what()) + " (lrf train: name it in place of the scene, `lrf train SCENE -o " +
                given.out + " --resume`)");
  }
  if (root == recorded_scene && given.scene != root && given.scene != given.out)
    log_warn("--resume: training on " + root + " as recorded in " + path + " (not " + given.scene + ")");
  return root;
}

}  // namespace lrf
