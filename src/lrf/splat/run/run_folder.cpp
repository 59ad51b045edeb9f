#include "lrf/splat/run/run_folder.h"

#include <cmath>
#include <filesystem>

#include "lrf/core/error.h"
#include "lrf/core/run_info.h"
#include "lrf/scene/run_scene_location.h"
#include "lrf/splat/ply_io.h"
#include "lrf/splat/run/render_size.h"

namespace fs = std::filesystem;

namespace lrf::splat {

nlohmann::json scene_config(const std::string& scene_root, const SceneOptions& o, const Scene& scene,
                            const std::string& run_folder) {
  nlohmann::json j = scene_location_record(scene_root, run_folder);
  j["scene_format"] = scene.format;
  j["images"] = o.images_dir;
  j["downscale"] = o.downscale;
  j["crop_to_multiple_of_8"] = o.crop_to_multiple_of_8;
  j["test_every"] = o.test_every;
  j["few_shot_views"] = o.train_views;
  j["test_list"] = o.test_list.empty() ? "" : fs::absolute(o.test_list).lexically_normal().string();
  if (!scene.views.empty())
    j["resolution"] = {scene.views.front().camera.width, scene.views.front().camera.height};
  j["train_views"] = scene.train_indices.size();
  j["test_views"] = scene.test_indices.size();
  if (o.train_views > 0) {  // few-shot: which views, so the choice can be checked against other tools
    nlohmann::json names = nlohmann::json::array();
    for (int i : scene.train_indices) names.push_back(scene.views[static_cast<size_t>(i)].name);
    j["few_shot_view_names"] = names;
  }
  return j;
}

nlohmann::json read_run_config(const std::string& out) {
  const std::string path = (fs::path(out) / "config.json").string();
  if (!fs::exists(path)) fail(path, "not found: is " + out + " a folder made by 'lrf train'?");
  return read_json_file(path);
}

FieldRun open_field_run(const std::string& out) {
  FieldRun run;
  run.out = out;
  const std::string config_path = (fs::path(out) / "config.json").string();
  run.config = read_run_config(out);
  const FieldConfig c = parse_field_config(run.config, config_path);
  if (c.kind != FieldKind::rgb) fail(config_path, "space '" + field_kind_name(c.kind) + "' cannot be rendered as RGB by this command yet");
  run.render.sh_degree = c.sh_degree;
  run.render.mip = c.mip;
  run.render.background = torch::tensor(c.background);
  const std::string scene_root = run_scene_root(run.config, config_path);
  run.scene = load_scene(scene_root, c.scene);
  check_run_scene_views(run.scene, run.config, config_path);
  run.config["scene"] = scene_root;  // where it was found, for whatever reads the config from here
  const std::string ply = (fs::path(out) / "point_cloud.ply").string();
  if (!fs::exists(ply)) fail(ply, "not found: the run has not finished (resume it with lrf train --resume)");
  run.field = read_ply(ply);
  if (run.render.background.numel() != run.field.channels())
    fail(config_path, "background has " + std::to_string(run.render.background.numel()) + " channels, the field " +
                          std::to_string(run.field.channels()));
  return run;
}

Camera scaled_camera(const Camera& camera, double scale, int width, int height) {
  check_render_options(scale, width, height);
  if (width > 0 && height > 0) return camera.resized(width, height);
  if (scale == 1.0) return camera;
  check_scaled_size(camera.width, camera.height, scale);
  return camera.resized(std::max(1, int(std::lround(camera.width * scale))),
                        std::max(1, int(std::lround(camera.height * scale))));
}

}  // namespace lrf::splat
