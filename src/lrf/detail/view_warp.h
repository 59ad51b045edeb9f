#pragma once
// Carrying a training photograph into another camera with a field's geometry: every pixel of the target
// view is lifted to 3D at the depth the field renders there and looked up in the source photograph,
// unless the field says the source camera sees something nearer along that ray (occluded) or the point
// falls outside the source image.
#include <vector>

#include <opencv2/core.hpp>

#include "lrf/scene/camera.h"

namespace lrf::detail {

// A source photograph carried into the target camera.
struct WarpedView {
  cv::Mat image;  // CV_32FC3, the target's size; 0 where not valid
  cv::Mat valid;  // CV_32F, 1 where the source sees the target's surface point, else 0
};

// `target_depth` and `source_depth` are CV_32F depth maps (camera-space z, 0 = no surface) of the size of
// their cameras; `source_image` is CV_32FC3 of the source camera's size. A target pixel is valid when its
// depth is positive, its point lies in front of the source camera and inside its image, and the source's
// own depth there is not nearer than the point's by more than `occlusion_tolerance` (a fraction of the
// depth). Colours are sampled bilinearly at the projected pixel centre.
WarpedView warp_view(const cv::Mat& source_image, const cv::Mat& source_depth, const Camera& source,
                     const cv::Mat& target_depth, const Camera& target, double occlusion_tolerance);

// Per pixel, how far warped photographs disagree: the variance of the colours of those valid there (the mean
// over channels; CV_32F), with `seen` (CV_32F) 1 where at least two are valid and 0 (variance 0) elsewhere.
cv::Mat colour_variance(const std::vector<WarpedView>& warped, cv::Size size, cv::Mat* seen);

}  // namespace lrf::detail
