#pragma once
// Where a job may not write: a scene is the user's input, read and never changed.
#include <string>

#include "lrf/scene/scene.h"

namespace lrf {

// refuse_output_over_input (core/paths.h) for a folder: the scene's own folder and every folder the scene's
// images are read from (writing renders there would replace photos of the same name, or add images the
// scene would read next time).
void refuse_output_in_scene(const std::string& output, const Scene& scene);

// refuse_output_over_input for a file: the scene's SfM points file and each of its images.
void refuse_output_over_scene_files(const std::string& output, const Scene& scene);

}  // namespace lrf
