#pragma once
// A NeRF-format scene: transforms_train/val/test.json (NeRF synthetic) or one transforms.json (instant-ngp, nerfstudio).
#include <string>

#include "lrf/scene/raw_scene.h"

namespace lrf {

RawScene read_nerf_scene(const std::string& root);
}  // namespace lrf
