#include "lrf/splat/run/run_config.h"

#include <cmath>
#include <cstdint>

#include "lrf/core/error.h"

namespace lrf::splat {
namespace {

// An integer setting within [lo, hi]; nlohmann's get<int> would silently wrap or (from a float) be
// undefined behaviour for out-of-range values.
int bounded_int(const nlohmann::json& c, const char* key, const std::string& path, int64_t lo, int64_t hi) {
  const auto& v = c.at(key);
  if (!v.is_number_integer()) fail(path, std::string("\"") + key + "\" is not an integer");
  if (v.is_number_unsigned() ? v.get<uint64_t>() > static_cast<uint64_t>(hi)
                             : (v.get<int64_t>() < lo || v.get<int64_t>() > hi)) {
    fail(path, std::string("\"") + key + "\" must be between " + std::to_string(lo) + " and " + std::to_string(hi));
  }
  return static_cast<int>(v.get<int64_t>());
}

}  // namespace

SceneOptions scene_options_from_config(const nlohmann::json& c, const std::string& path) {
  if (!c.is_object()) fail(path, "not a JSON object: is it the config.json of 'lrf train'?");
  SceneOptions o;
  try {
    o.images_dir = c.at("images").get<std::string>();
    o.downscale = bounded_int(c, "downscale", path, 1, 1 << 16);
    o.crop_to_multiple_of_8 = c.value("crop_to_multiple_of_8", false);
    o.test_every = bounded_int(c, "test_every", path, 0, 1 << 30);
    o.test_list = c.value("test_list", std::string());
    if (c.contains("few_shot_views")) o.train_views = bounded_int(c, "few_shot_views", path, 0, 1 << 30);
    o.format = c.value("scene_format", std::string());
  } catch (const nlohmann::json::exception& e) {
    fail(path, std::string("missing or bad scene settings: ") + e.what());
  }
  return o;
}

FieldConfig parse_field_config(const nlohmann::json& c, const std::string& path) {
  FieldConfig f;
  f.kind = field_kind_of_config(c, path);
  if (f.kind == FieldKind::latent_nerf) fail(path, "a latent NeRF (lrf train --space latent-nerf), not a Gaussian field");
  try {
    f.scene_root = c.at("scene").get<std::string>();
    f.sh_degree = bounded_int(c, "sh_degree", path, 0, 3);
    f.mip = f.kind == FieldKind::rgb ? c.at("mip").get<bool>() : false;  // latent fields are rendered without it
    f.background = c.at("background").get<std::vector<float>>();
  } catch (const nlohmann::json::exception& e) {
    fail(path, std::string("missing or bad field settings: ") + e.what());
  }
  if (f.background.empty() || f.background.size() > 1024) fail(path, "\"background\" must have 1 to 1024 channels");
  for (float b : f.background)
    if (!std::isfinite(b)) fail(path, "\"background\" holds a value that is not a finite float");
  f.scene = scene_options_from_config(c, path);
  return f;
}

}  // namespace lrf::splat
