#pragma once
// The settings of a trained output folder's config.json that reopening it needs (lrf render / eval /
// compare), parsed and checked without touching the file system: a damaged or hand-edited config.json is
// refused with an lrf::Error naming the file and the key, never a crash or an absurd allocation.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lrf/scene/scene.h"

namespace lrf::splat {

struct FieldConfig {
  std::string space;       // "rgb" or "latent"
  std::string scene_root;  // the scene it was trained on
  SceneOptions scene;      // how that scene was loaded
  int sh_degree = 0;
  bool mip = false;
  std::vector<float> background;  // one value per channel
};

// "rgb" (also when absent, as in runs older than Stage II), "latent" or "latent-nerf" (nerf/nerf_run.h).
std::string config_space(const nlohmann::json& config, const std::string& config_path);
SceneOptions scene_options_from_config(const nlohmann::json& config, const std::string& config_path);
// The render settings and scene of any Gaussian field's config.json (RGB or latent; a latent NeRF is refused).
FieldConfig parse_field_config(const nlohmann::json& config, const std::string& config_path);

}  // namespace lrf::splat
