#pragma once
// The scenes of a pipeline run, from --train-scenes and --eval-scenes, each "PATH" or PATH with its own
// resolution ("PATH:--images=DIR", "PATH:--downscale=N", scene_spec.h): parsed and checked before any
// stage starts, so that a typo in the last evaluation scene does not surface hours later, and the
// resolution every field and score of each scene is made at.
#include <map>
#include <string>
#include <vector>

#include "lrf/scene/scene_spec.h"

namespace lrf {

struct PipelineScenes {
  std::vector<std::string> train, eval;          // scene folders, in the order given
  std::map<std::string, std::string> argument;   // by folder: the argument it was given as
  std::map<std::string, SceneResolution> given;  // by folder: the options after it (default when none)
  // By folder: the image folder and the downscale in use: the given ones, the downscale otherwise the
  // smallest that brings the longer side of those images to at most --max-side.
  std::map<std::string, SceneResolution> used;

  // True if some scene of `folders` was given options of its own.
  bool any_given(const std::vector<std::string>& folders) const;
};

// Parses both lists. Throws lrf::UsageError naming the list option and the argument for option text it
// cannot parse, and lrf::Error naming the folder for a scene or image folder that does not exist, two
// scenes with the same folder name, a scene in both lists, or a scene whose images its resolution makes
// too small. Reads each scene's cameras (not its images).
PipelineScenes resolve_pipeline_scenes(const std::vector<std::string>& train, const std::vector<std::string>& eval,
                                       int max_side);

}  // namespace lrf
