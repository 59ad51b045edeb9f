#pragma once
// How steady a rendered camera path is: each frame is compared with the previous one carried into its
// camera by the field's depth (view_warp.h). Motion is taken out by the warp, so what remains is what changes
// between frames on the same surface point: flicker (and the warp's own error, the same for any renderer of
// one field along one path).
#include <opencv2/core.hpp>

#include "lrf/scene/camera.h"

namespace lrf::detail {

class FrameStability {
 public:
  // `frame` is 8-bit or float RGB, `depth` the field's depth for `camera` (FieldFrames::depth).
  void add(const cv::Mat& frame, const cv::Mat& depth, const Camera& camera);
  // The mean absolute difference, in 8-bit levels, between consecutive frames over the pixels both see;
  // 0 before two frames.
  double mean_warp_error() const { return pairs_ ? error_sum_ / pairs_ : 0.0; }
  long pairs() const { return pairs_; }

 private:
  cv::Mat previous_frame_, previous_depth_;
  Camera previous_camera_;
  double error_sum_ = 0;
  long pairs_ = 0;
};

}  // namespace lrf::detail
