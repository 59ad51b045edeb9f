#include "lrf/detail/frame_stability.h"

#include <cmath>

#include "lrf/core/image_io.h"
#include "lrf/detail/view_warp.h"

namespace lrf::detail {

void FrameStability::add(const cv::Mat& frame, const cv::Mat& depth, const Camera& camera) {
  const cv::Mat current = frame.type() == CV_8UC3 ? to_float(frame) : frame;
  if (!previous_frame_.empty()) {
    // A tolerance as the detail pass's: a point hidden in the previous frame is not compared.
    const WarpedView w = warp_view(previous_frame_, previous_depth_, previous_camera_, depth, camera, 0.05);
    double sum = 0;
    long count = 0;
    for (int i = 0; i < current.rows; ++i) {
      const cv::Vec3f* a = current.ptr<cv::Vec3f>(i);
      const cv::Vec3f* b = w.image.ptr<cv::Vec3f>(i);
      const float* v = w.valid.ptr<float>(i);
      for (int j = 0; j < current.cols; ++j) {
        if (v[j] <= 0) continue;
        sum += (std::abs(a[j][0] - b[j][0]) + std::abs(a[j][1] - b[j][1]) + std::abs(a[j][2] - b[j][2])) / 3.0;
        ++count;
      }
    }
    if (count > 0) {
      error_sum_ += 255.0 * sum / static_cast<double>(count);
      ++pairs_;
    }
  }
  previous_frame_ = current.clone();
  previous_depth_ = depth.clone();
  previous_camera_ = camera;
}

}  // namespace lrf::detail
