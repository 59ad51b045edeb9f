#pragma once
// An LLFF scene: poses_bounds.npy, its images folders (images, images_4, images_8, ...) and the COLMAP points beside them.
#include <string>

#include "lrf/scene/raw_scene.h"

namespace lrf {

RawScene read_llff_scene(const std::string& root, const std::string& images_dir);
}  // namespace lrf
