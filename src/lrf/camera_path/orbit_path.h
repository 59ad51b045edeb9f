#pragma once
// One turn around the scene's centre, at the cameras' mean height and distance (camera_path.h).
#include <string>
#include <vector>

#include "lrf/camera_path/camera_path.h"

namespace lrf::camera_path {

std::vector<Camera> orbit_path(const std::vector<Camera>& cameras, const std::vector<Eigen::Vector3d>& points,
                               const PathOptions& options, PathGeometry* geometry = nullptr);

// What an orbit turns around (and the viewer's first orbit target): the median of the SfM points when
// there are at least 10, else where the cameras' axes meet, else the cameras' mean centre. `source` says which.
Eigen::Vector3d orbit_center(const std::vector<Camera>& cameras, const std::vector<Eigen::Vector3d>& points,
                             std::string* source);

}  // namespace lrf::camera_path
