#pragma once
// Small pose helpers for building cameras along a path, in lrf's camera convention (OpenCV axes, x right,
// y down, z forward; R maps world to camera, so R's rows are the camera's axes in world coordinates).
#include <vector>

#include "lrf/scene/camera.h"

namespace lrf::camera_path {

// A camera at `eye` looking at `target`, rolled so that the world direction `up` points up in the image
// (as far as it can: `up` must not be parallel to the viewing direction). Intrinsics come from `intrinsics`.
// Throws lrf::Error when eye == target or up is parallel to the view.
Camera look_at(const Camera& intrinsics, const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
               const Eigen::Vector3d& up);

// The axes of a camera in world coordinates.
inline Eigen::Vector3d camera_right(const Camera& c) { return c.R.row(0).transpose(); }
inline Eigen::Vector3d camera_down(const Camera& c) { return c.R.row(1).transpose(); }
inline Eigen::Vector3d camera_forward(const Camera& c) { return c.R.row(2).transpose(); }

// The mean pose of a set of cameras: mean centre, mean viewing direction and mean up direction, made
// orthonormal. Throws lrf::Error on an empty set or when the directions cancel out.
struct MeanPose {
  Eigen::Vector3d center, right, down, forward;
};
MeanPose mean_pose(const std::vector<Camera>& cameras);

// The point closest (least squares) to every camera's optical axis; false when the axes are too close
// to parallel for that point to be well defined (forward-facing captures).
bool axes_convergence_point(const std::vector<Camera>& cameras, Eigen::Vector3d* point);

// The q-quantile (0..1, linear interpolation between order statistics) of `values` (copied).
double quantile(std::vector<double> values, double q);

}  // namespace lrf::camera_path
