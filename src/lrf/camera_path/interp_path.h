#pragma once
// A smooth path through the training views in order, passing exactly through each (camera_path.h).
#include <vector>

#include "lrf/camera_path/camera_path.h"

namespace lrf::camera_path {

std::vector<Camera> interp_path(const std::vector<Camera>& cameras, const PathOptions& options);

}  // namespace lrf::camera_path
