#pragma once
// Where a job may not write: a scene is the user's input, read and never changed.
#include <string>

#include "lrf/scene/scene.h"

namespace lrf {

// Throws lrf::UsageError naming `output` when it is the scene's own folder or a folder the scene's images are
// read from (writing renders there would replace photos of the same name, or add images the scene would
// read next time). `option` is the command-line option that named it, for the message.
void refuse_output_in_scene(const std::string& output, const Scene& scene, const std::string& option);

// Throws lrf::UsageError naming `output` when it is a file the scene was read from: its SfM points or one
// of its images.
void refuse_output_over_scene_files(const std::string& output, const Scene& scene, const std::string& option);

}  // namespace lrf
