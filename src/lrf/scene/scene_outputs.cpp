#include "lrf/scene/scene_outputs.h"

#include <filesystem>
#include <set>

#include "lrf/core/paths.h"

namespace lrf {

void refuse_output_in_scene(const std::string& output, const Scene& scene) {
  refuse_output_over_input(output, scene.root, "the scene folder");
  // One check per folder: a scene's views usually share one.
  std::set<std::string> image_folders;
  for (const auto& view : scene.views) {
    image_folders.insert(std::filesystem::path(view.image_path).parent_path().string());
  }
  for (const auto& folder : image_folders) refuse_output_over_input(output, folder, "the folder of the scene's images");
}

void refuse_output_over_scene_files(const std::string& output, const Scene& scene) {
  if (!scene.points_file.empty()) refuse_output_over_input(output, scene.points_file, "the scene's points file");
  for (const auto& view : scene.views) refuse_output_over_input(output, view.image_path, "one of the scene's images");
}

}  // namespace lrf
