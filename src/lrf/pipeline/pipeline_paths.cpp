#include "lrf/pipeline/pipeline_paths.h"

#include <filesystem>

#include "lrf/core/paths.h"

namespace fs = std::filesystem;

namespace lrf {

std::string scene_name(const std::string& root) { return fs::path(canonical_path(root)).filename().string(); }

std::string protocol_suffix(int train_views) {
  return train_views > 0 ? "-" + std::to_string(train_views) + "views" : std::string();
}

std::string PipelinePaths::field(const std::string& scene, const std::string& tag) const {
  return (fs::path(root) / "fields" / (scene_name(scene) + "-" + tag)).string();
}

std::string PipelinePaths::eval_field(const std::string& scene, const std::string& tag) const {
  return (fs::path(root) / "fields" / (eval_label(scene) + "-" + tag)).string();
}

std::string PipelinePaths::encoder() const { return (fs::path(root) / "stage1" / "encoder.safetensors").string(); }

std::string PipelinePaths::decoder(const std::string& tag) const {
  return (fs::path(root) / "stage3" / ("decoder-" + tag + ".safetensors")).string();
}

std::string PipelinePaths::eval(const std::string& scene, const std::string& row) const {
  return (fs::path(root) / "eval" / eval_label(scene) / row).string();
}

std::string PipelinePaths::eval_label(const std::string& scene) const { return scene_name(scene) + protocol; }

std::string PipelinePaths::output(const std::string& stem, const std::string& extension) const {
  return (fs::path(root) / (stem + protocol + "." + extension)).string();
}

}  // namespace lrf
