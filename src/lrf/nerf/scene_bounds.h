#pragma once
// Where a NeRF looks for the scene. Rays are sampled between a near and a far camera depth, uniformly in
// disparity (1/depth): NeRF's sampling of forward-facing LLFF scenes in NDC space is uniform in disparity
// too, and it spends samples where a pixel's footprint is small. Positions are mapped into a box (the
// bulk of the scene's points) and everything outside the box is contracted into a shell around it
// (Mip-NeRF 360's contraction, with the max-norm so the result is a cube a grid covers without waste):
//   y = x            when ‖x‖∞ ≤ 1
//   y = (2 − 1/‖x‖∞) x/‖x‖∞  otherwise,   x = (p − center) / half   (per axis)
// so the whole of space lands in [−2, 2]³, which the hash grid covers as [0, 1]³. One rule for
// forward-facing captures (the far background is contracted) and object captures (the box holds them).
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "lrf/scene/camera.h"

namespace lrf::nerf {

struct SceneBounds {
  double near = 0.1, far = 10.0;  // camera depth (z in the camera frame) of the first and last sample
  Eigen::Vector3d center = Eigen::Vector3d::Zero(), half = Eigen::Vector3d::Ones();
  double unit = 1.0;  // length unit of densities: σ is per `unit` of distance (the box's mean half-extent)

  // Grid coordinates in [0, 1]³ of a world point (contracted as above).
  Eigen::Vector3d grid_coordinates(const Eigen::Vector3d& world) const;
  nlohmann::json to_json() const;
  // Throws lrf::Error naming `path` when a value is missing, not finite or out of order.
  static SceneBounds from_json(const nlohmann::json& j, const std::string& path);
};

// Bounds from the scene's points as seen by the training cameras: near and far from the 0.1 and 99.9
// percentiles of the points' depths in each view (as LLFF's poses_bounds.npy are made), widened by 10%
// and 20%; the box from the 2nd to 98th percentile of the points on each axis, widened by 10%. Without
// points (random initialisation): the cameras' mean and extent.
SceneBounds bounds_from_points(const std::vector<Camera>& cameras, const std::vector<Eigen::Vector3d>& points,
                               const Eigen::Vector3d& camera_mean, double camera_extent);

}  // namespace lrf::nerf
