#pragma once
// LLFF's forward-facing spiral around the mean training pose (camera_path.h).
#include <string>
#include <vector>

#include "lrf/camera_path/camera_path.h"

namespace lrf::camera_path {

std::vector<Camera> spiral_path(const std::vector<Camera>& cameras, const std::vector<Eigen::Vector3d>& points,
                                const PathOptions& options, PathGeometry* geometry = nullptr);

}  // namespace lrf::camera_path
