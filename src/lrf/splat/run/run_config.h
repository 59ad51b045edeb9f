#pragma once
// The settings of a trained output folder's config.json that reopening it needs (lrf render / eval /
// compare), parsed and checked without touching the file system: a damaged or hand-edited config.json is
// refused with an lrf::Error naming the file and the key, never a crash or an absurd allocation.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lrf/scene/scene.h"
#include "lrf/splat/run/field_kind.h"

namespace lrf::splat {

struct FieldConfig {
  FieldKind kind = FieldKind::rgb;  // rgb or latent (a latent NeRF is not a Gaussian field)
  std::string scene_root;  // the scene it was trained on
  SceneOptions scene;      // how that scene was loaded
  int sh_degree = 0;
  bool mip = false;
  std::vector<float> background;  // one value per channel
};

SceneOptions scene_options_from_config(const nlohmann::json& config, const std::string& config_path);
// The render settings and scene of any Gaussian field's config.json (RGB or latent; a latent NeRF is refused).
FieldConfig parse_field_config(const nlohmann::json& config, const std::string& config_path);

}  // namespace lrf::splat
