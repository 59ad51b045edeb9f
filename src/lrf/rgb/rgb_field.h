#pragma once
// RGB as a user of the generic trainer: scene images as [3, H, W] targets, and the starting field
// from the points choose_initial_points picks (the scene's SfM points, triangulated ones, a file; with
// their colours) or random points around the cameras.
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <torch/types.h>

#include "lrf/points/initial_points.h"

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
// On the points that choose_initial_points picks with `points`. `origin`, when given, receives
// InitialPoints::record (where the points came from) for the run's config.json.
Gaussians init_rgb_field(const Scene& scene, int max_sh_degree, uint64_t seed,
                         const InitPointsOptions& points = InitPointsOptions{}, nlohmann::json* origin = nullptr);

}  // namespace lrf::splat
