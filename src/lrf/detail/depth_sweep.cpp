#include "lrf/detail/depth_sweep.h"

#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "lrf/detail/view_warp.h"

namespace lrf::detail {

cv::Mat sweep_depth(const cv::Mat& depth, const Camera& target, const std::vector<SweepSource>& sources,
                    const DepthSweepOptions& options) {
  if (options.range <= 0 || options.steps < 2 || sources.size() < 2) return depth.clone();
  const cv::Size size = depth.size();
  cv::Mat best_cost(size, CV_32F, cv::Scalar(std::numeric_limits<float>::infinity()));
  cv::Mat best = depth.clone();
  const cv::Size window(options.window, options.window);
  for (int s = 0; s < options.steps; ++s) {
    const double offset = options.range * (2.0 * s / (options.steps - 1) - 1.0);
    const cv::Mat shifted = depth * (1.0 + offset);
    // The photographs' disagreement at this depth, averaged over the window.
    std::vector<WarpedView> warped;
    for (const auto& source : sources)
      warped.push_back(
          warp_view(*source.image, *source.depth, *source.camera, shifted, target, options.occlusion_tolerance));
    cv::Mat seen;
    const cv::Mat variance = colour_variance(warped, size, &seen);
    cv::Mat window_variance, window_seen;
    cv::boxFilter(variance, window_variance, CV_32F, window, cv::Point(-1, -1), true, cv::BORDER_REFLECT);
    cv::boxFilter(seen, window_seen, CV_32F, window, cv::Point(-1, -1), true, cv::BORDER_REFLECT);
    const float stay = static_cast<float>(options.stay_cost * std::abs(offset) / options.range);
    for (int i = 0; i < size.height; ++i) {
      const float* v = window_variance.ptr<float>(i);
      const float* ok = window_seen.ptr<float>(i);
      const float* here = seen.ptr<float>(i);
      const float* d = shifted.ptr<float>(i);
      float* c = best_cost.ptr<float>(i);
      float* b = best.ptr<float>(i);
      for (int j = 0; j < size.width; ++j) {
        if (here[j] <= 0 || ok[j] < 0.5f || !(d[j] > 0)) continue;
        const float cost = v[j] / ok[j] + stay;
        if (cost < c[j]) {
          c[j] = cost;
          b[j] = d[j];
        }
      }
    }
  }
  return best;
}

}  // namespace lrf::detail
