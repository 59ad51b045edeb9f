#pragma once
// Reopening a trained output folder (OUT/config.json + OUT/point_cloud.ply) to render or evaluate it:
// the scene it was trained on, at the resolution used, the stored field, and its render settings.
#include <string>

#include <nlohmann/json.hpp>

#include "lrf/scene/scene.h"
#include "lrf/splat/run/run_config.h"
#include "lrf/splat/gaussians.h"
#include "lrf/splat/render_field.h"

namespace lrf::splat {

struct FieldRun {
  std::string out;
  nlohmann::json config;
  Scene scene;
  Gaussians field;
  FieldRenderOptions render;
};

// The keys of config.json that describe how to reload the scene and render the field, for a run written to
// `run_folder` (the scene's place is recorded relative to it too).
nlohmann::json scene_config(const std::string& scene_root, const SceneOptions& options, const Scene& scene,
                            const std::string& run_folder);

// OUT/config.json of a trained run of any kind; throws lrf::Error naming it when OUT holds none.
nlohmann::json read_run_config(const std::string& out);

// Throws lrf::Error naming the file when config.json or point_cloud.ply is missing or inconsistent, or the
// scene is not where config.json (or --scene, set_scene_override) says.
FieldRun open_field_run(const std::string& out);

// A view's camera at `scale` times the training resolution, or at width x height when both are > 0;
// throws lrf::UsageError outside the bounds of render_size.h.
Camera scaled_camera(const Camera& camera, double scale, int width, int height);

}  // namespace lrf::splat
