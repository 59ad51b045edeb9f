#pragma once
// RGB as a user of the generic trainer: scene images as [3, H, W] targets, and the starting field
// from the scene's SfM points (their colours) or, without points, random points around the cameras.
#include <vector>

#include <opencv2/core.hpp>
#include <torch/types.h>

#include "lrf/scene/scene.h"
#include "lrf/splat/gaussians.h"
#include "lrf/splat/train/trainer.h"

namespace lrf::splat {

// CV_32FC3 RGB [H, W] <-> float32 [3, H, W] (copies).
torch::Tensor image_to_tensor(const cv::Mat& rgb);
cv::Mat tensor_to_image(const torch::Tensor& chw);

std::vector<TrainView> rgb_views(const Scene& scene, const std::vector<int>& indices);

// Random initialisation: this many points, uniform in a cube around the cameras' mean whose half-size
// is the scene extent (cameras' spread), with random colours.
constexpr int64_t kRandomInitPoints = 100000;
Gaussians init_rgb_field(const Scene& scene, int max_sh_degree, uint64_t seed);

}  // namespace lrf::splat
