#pragma once
// Sharpening a field's depth with the photographs themselves (a plane sweep around it): a latent field's
// geometry was fitted to 1/8-resolution latents, so its depth may be off by enough to misplace fine detail
// by a pixel or two. Around the rendered depth, each pixel takes the depth at which the nearest training
// photographs, carried into the view, agree best with one another over a small window.
#include <vector>

#include <opencv2/core.hpp>

#include "lrf/scene/camera.h"

namespace lrf::detail {

struct SweepSource {
  const cv::Mat* image;  // CV_32FC3 at `camera`
  const cv::Mat* depth;  // CV_32F, the field's depth from `camera`
  const Camera* camera;
};

struct DepthSweepOptions {
  double range = 0.0;               // relative depth offsets tried: [-range, +range] (0 = no sweep)
  int steps = 9;                    // offsets tried (odd, so that the rendered depth is one of them)
  int window = 5;                   // side of the square over which the photographs' disagreement is summed
  double occlusion_tolerance = 0.02;
  double stay_cost = 1e-4;          // added per unit of |offset| / range, so that flat regions keep the field's depth
};

// Returns the refined depth (CV_32F, the target's size; 0 where `depth` is 0). Pixels seen by fewer than two
// of `sources` at every offset keep their depth.
cv::Mat sweep_depth(const cv::Mat& depth, const Camera& target, const std::vector<SweepSource>& sources,
                    const DepthSweepOptions& options);

}  // namespace lrf::detail
