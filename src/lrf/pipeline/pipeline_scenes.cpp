#include "lrf/pipeline/pipeline_scenes.h"

#include <filesystem>
#include <set>
#include <tuple>

#include "lrf/core/error.h"
#include "lrf/core/paths.h"
#include "lrf/finetune/pair_batches.h"
#include "lrf/pipeline/pipeline.h"
#include "lrf/scene/scene.h"

namespace fs = std::filesystem;

namespace lrf {

bool PipelineScenes::any_given(const std::vector<std::string>& folders) const {
  for (const auto& f : folders) {
    if (!given.at(f).is_default()) return true;
  }
  return false;
}

PipelineScenes resolve_pipeline_scenes(const std::vector<std::string>& train, const std::vector<std::string>& eval,
                                       int max_side) {
  PipelineScenes scenes;
  std::set<std::string> names;
  for (const auto& [option, arguments, folders] :
       {std::tuple{"--train-scenes", &train, &scenes.train}, std::tuple{"--eval-scenes", &eval, &scenes.eval}}) {
    for (const std::string& argument : *arguments) {
      SceneSpec spec;
      try {
        spec = parse_scene_spec(argument);
      } catch (const UsageError& e) {
        fail_usage(std::string(option) + ": " + e.what());
      }
      check_scene_spec_folders(spec, argument);
      folders->push_back(spec.path);
      scenes.argument[spec.path] = argument;
      scenes.given[spec.path] = spec.resolution;
    }
  }
  check_no_overlap(scenes.train, scenes.eval);
  // Every artefact of a scene is named after its folder.
  for (const auto* folders : {&scenes.train, &scenes.eval}) {
    for (const std::string& folder : *folders) {
      const std::string name = fs::path(canonical_path(folder)).filename().string();
      if (!names.insert(name).second) fail(folder, "two scenes share the folder name '" + name + "'");
    }
  }
  for (const auto* folders : {&scenes.train, &scenes.eval}) {
    for (const std::string& folder : *folders) {
      const SceneResolution& given = scenes.given[folder];
      SceneResolution used = given;
      if (used.downscale == 0) {
        used.downscale = downscale_for_max_side(folder, given.images, max_side);
      }
      if (given.downscale > 0) {
        // The loader refuses views made too small by the downscale; here, before any stage, rather than at
        // the scene's first field. (A downscale from --max-side keeps the images as large as allowed.)
        SceneOptions probe;
        probe.images_dir = used.images;
        probe.downscale = used.downscale;
        probe.crop_to_multiple_of_8 = true;
        try {
          load_scene(folder, probe);
        } catch (const Error& e) {
          fail(scenes.argument[folder], e.what());
        }
      }
      scenes.used[folder] = used;
    }
  }
  return scenes;
}

}  // namespace lrf
