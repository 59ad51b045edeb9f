#pragma once
// Lens undistortion onto the same pinhole intrinsics (OpenCV's models: radial-tangential and fisheye).
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "lrf/scene/camera.h"

namespace lrf {

// Remaps a distorted image (the size of `cam`) so that it follows the pinhole camera `cam` (Lanczos,
// clipped to the input's range).
cv::Mat undistort_image(const cv::Mat& image, const Camera& cam, const Distortion& d);
// Maps distorted pixel coordinates to the pinhole camera `cam` with the same intrinsics.
std::vector<Eigen::Vector2d> undistort_points(const std::vector<Eigen::Vector2d>& pixels, const Camera& cam,
                                              const Distortion& d);
// The forward model: pinhole pixel -> distorted pixel (used by tests and the synthetic scene).
Eigen::Vector2d distort_point(const Eigen::Vector2d& pixel, const Camera& cam, const Distortion& d);

}  // namespace lrf
