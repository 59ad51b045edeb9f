#include "lrf/scene/scene_outputs.h"

#include <filesystem>
#include <set>

#include "lrf/core/error.h"
#include "lrf/core/paths.h"

namespace lrf {

void refuse_output_in_scene(const std::string& output, const Scene& scene, const std::string& option) {
  if (same_path(output, scene.root)) {
    fail_usage(output + ": " + option + " is the scene folder itself, which lrf only reads: write the output elsewhere");
  }
  std::set<std::string> image_folders;
  for (const auto& view : scene.views) {
    image_folders.insert(std::filesystem::path(view.image_path).parent_path().string());
  }
  for (const auto& folder : image_folders) {
    if (same_path(output, folder)) {
      fail_usage(output + ": " + option + " is the folder the scene's images are read from, which lrf only reads: "
                 "write the output elsewhere");
    }
  }
}

void refuse_output_over_scene_files(const std::string& output, const Scene& scene, const std::string& option) {
  if (!scene.points_file.empty() && same_path(output, scene.points_file)) {
    fail_usage(output + ": " + option + " is the scene's own points file, which lrf only reads: write the output "
                                         "elsewhere");
  }
  for (const auto& view : scene.views) {
    if (same_path(output, view.image_path)) {
      fail_usage(output + ": " + option + " is one of the scene's images, which lrf only reads: write the output "
                                           "elsewhere");
    }
  }
}

}  // namespace lrf
