#pragma once
// A COLMAP scene: images/ and sparse/0 (cameras, images and points3D, binary or text).
#include <string>

#include "lrf/scene/raw_scene.h"

namespace lrf {

RawScene read_colmap_scene(const std::string& root);
// The points3D file of a COLMAP model folder (.bin preferred, as read_colmap_model does); "" if none.
std::string colmap_points_path(const std::string& sparse_dir);
}  // namespace lrf
