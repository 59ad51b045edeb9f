#pragma once
// Where a trained run's scene is. config.json records the scene folder twice: absolute ("scene") and
// relative to the run folder ("scene_relative"), so that moving a project folder that holds both keeps its
// runs working; `--scene DIR` on the command line names the folder outright after the scene alone moved.
#include <string>

#include <nlohmann/json.hpp>

#include "lrf/scene/scene.h"

namespace lrf {

// The "scene" and "scene_relative" keys for a run written to `run_folder` (which need not exist yet).
nlohmann::json scene_location_record(const std::string& scene_root, const std::string& run_folder);

// The command line's `--scene DIR` for every run this process reopens ("" = none: use the recorded place).
void set_scene_override(const std::string& scene_root);
const std::string& scene_override();

// The scene folder of the run whose config.json is `config_path`: --scene when given (it must exist),
// else the recorded absolute path, else the recorded relative one. Throws lrf::Error naming the missing
// folder and suggesting --scene when none exists.
std::string run_scene_root(const nlohmann::json& config, const std::string& config_path);

// The scene folder of a run that `lrf train SCENE -o OUT --resume` continues: as run_scene_root, but when the
// recorded places are gone, `named` (SCENE; "" = none) once it is seen to have the recorded numbers of
// training and test views, read with the run's `options` (after the scene alone moved).
std::string resumed_run_scene_root(const nlohmann::json& config, const std::string& config_path,
                                   const std::string& named, const SceneOptions& options);

// Throws lrf::Error when `scene` (reloaded with the run's scene options) has not the numbers of training and
// test views that config.json recorded at training: another scene given with --scene, or one that changed.
void check_run_scene_views(const Scene& scene, const nlohmann::json& config, const std::string& config_path);

}  // namespace lrf
