#include "lrf/scene/run_scene_location.h"

#include <filesystem>

#include "lrf/core/error.h"
#include "lrf/core/log.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

std::string g_override;

// Absolute and normalised, without a trailing separator, symlinks kept: how "scene" is recorded.
fs::path absolute_normal(const std::string& path) {
  fs::path p = fs::absolute(path).lexically_normal();
  if (p.filename().empty() && p.has_parent_path()) p = p.parent_path();
  return p;
}

size_t recorded_count(const nlohmann::json& config, const char* key, const std::string& config_path) {
  const auto& v = config.at(key);
  if (!v.is_number_unsigned()) fail(config_path, std::string("\"") + key + "\" is not a count of views");
  return v.get<size_t>();
}

// The recorded numbers of views against `scene`'s; `named` is the folder the command line gave (by `how`),
// "" when the scene is the recorded one.
void check_views(const Scene& scene, const nlohmann::json& config, const std::string& config_path,
                 const std::string& named, const std::string& how) {
  if (!config.contains("train_views") || !config.contains("test_views")) return;  // runs older than the record
  const size_t train = recorded_count(config, "train_views", config_path);
  const size_t test = recorded_count(config, "test_views", config_path);
  if (scene.train_indices.size() == train && scene.test_indices.size() == test) return;
  const std::string found = std::to_string(scene.views.size()) + " views (" +
                            std::to_string(scene.train_indices.size()) + " training, " +
                            std::to_string(scene.test_indices.size()) + " test)";
  const std::string expected = std::to_string(train) + " training and " + std::to_string(test) + " test views";
  if (!named.empty()) {
    fail(named, how + ": this scene has " + found + " but the run in " +
                    absolute_normal(config_path).parent_path().string() + " was trained on " + expected +
                    ": is it the same scene?");
  }
  fail(scene.root, "the scene has " + found + " but the run was trained on " + expected + " (" + config_path +
                       "): it changed since training");
}

}  // namespace

nlohmann::json scene_location_record(const std::string& scene_root, const std::string& run_folder) {
  const fs::path scene = absolute_normal(scene_root);
  return {{"scene", scene.string()}, {"scene_relative", scene.lexically_relative(absolute_normal(run_folder)).string()}};
}

void set_scene_override(const std::string& scene_root) { g_override = scene_root; }
const std::string& scene_override() { return g_override; }

std::string run_scene_root(const nlohmann::json& config, const std::string& config_path) {
  if (!g_override.empty()) {
    std::error_code ec;
    if (!fs::is_directory(g_override, ec)) fail(g_override, "--scene: scene folder not found");
    return absolute_normal(g_override).string();
  }
  if (!config.is_object() || !config.contains("scene") || !config["scene"].is_string())
    fail(config_path, "no \"scene\" (the scene folder the run was trained on)");
  const std::string recorded = config["scene"].get<std::string>();
  std::error_code ec;
  if (fs::exists(recorded, ec)) return recorded;
  std::string tried = recorded;
  if (config.contains("scene_relative") && config["scene_relative"].is_string()) {
    const fs::path run_folder = absolute_normal(config_path).parent_path();
    const fs::path moved = (run_folder / config["scene_relative"].get<std::string>()).lexically_normal();
    if (fs::is_directory(moved, ec)) {
      log_info("the scene is no longer at " + recorded + "; reading it at " + moved.string() +
               ", where it lies relative to the run folder as it did at training");
      return moved.string();
    }
    tried += " nor at " + moved.string() + " (its place relative to the run)";
  }
  fail(config_path, "the scene this run was trained on is not at " + tried +
                        ": it was moved or deleted; give its folder with --scene DIR");
}

std::string resumed_run_scene_root(const nlohmann::json& config, const std::string& config_path,
                                   const std::string& named, const SceneOptions& options) {
  if (named.empty()) return run_scene_root(config, config_path);
  try {
    return run_scene_root(config, config_path);
  } catch (const Error&) {
    // Neither recorded place (nor --scene) holds it: the scene this command line names is tried next.
  }
  std::error_code ec;
  if (!fs::is_directory(named, ec)) fail(named, "scene folder not found");
  const std::string root = absolute_normal(named).string();
  check_views(load_scene(root, options), config, config_path, root, "lrf train SCENE --resume");
  log_info("--resume: the recorded scene has moved; training on " + root);
  return root;
}

void check_run_scene_views(const Scene& scene, const nlohmann::json& config, const std::string& config_path) {
  check_views(scene, config, config_path, g_override, "--scene");
}

}  // namespace lrf
