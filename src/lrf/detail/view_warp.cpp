#include "lrf/detail/view_warp.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Core>

#include "lrf/core/error.h"

namespace lrf::detail {
namespace {

void check_map(const cv::Mat& m, int type, const Camera& camera, const char* what) {
  if (m.type() != type || m.cols != camera.width || m.rows != camera.height)
    fail(std::string("warp_view: ") + what + " is " + std::to_string(m.cols) + "x" + std::to_string(m.rows) +
         " of type " + std::to_string(m.type()) + ", expected " + std::to_string(camera.width) + "x" +
         std::to_string(camera.height) + " of type " + std::to_string(type));
}

// The depth the source renders at a continuous pixel position: the nearest pixel's, since blending depths
// across a silhouette would invent surfaces between the two.
float depth_at(const cv::Mat& depth, double x, double y) {
  const int j = static_cast<int>(std::floor(x)), i = static_cast<int>(std::floor(y));
  return depth.at<float>(i, j);
}

// Bilinear colour at continuous position (x, y) in pixel units with centres at integer + 0.5; the caller
// guarantees 0.5 <= x <= W - 0.5 and the same for y, so every tap is inside.
cv::Vec3f colour_at(const cv::Mat& image, double x, double y) {
  const double fx = x - 0.5, fy = y - 0.5;
  const int j0 = std::min(static_cast<int>(std::floor(fx)), image.cols - 2);
  const int i0 = std::min(static_cast<int>(std::floor(fy)), image.rows - 2);
  const float ax = static_cast<float>(fx - j0), ay = static_cast<float>(fy - i0);
  const cv::Vec3f* r0 = image.ptr<cv::Vec3f>(i0);
  const cv::Vec3f* r1 = image.ptr<cv::Vec3f>(i0 + 1);
  return (r0[j0] * (1 - ax) + r0[j0 + 1] * ax) * (1 - ay) + (r1[j0] * (1 - ax) + r1[j0 + 1] * ax) * ay;
}

}  // namespace

WarpedView warp_view(const cv::Mat& source_image, const cv::Mat& source_depth, const Camera& source,
                     const cv::Mat& target_depth, const Camera& target, double occlusion_tolerance) {
  check_map(source_image, CV_32FC3, source, "the source image");
  check_map(source_depth, CV_32F, source, "the source depth");
  check_map(target_depth, CV_32F, target, "the target depth");
  if (source.width < 2 || source.height < 2) fail("warp_view: the source image is smaller than 2x2");
  WarpedView out{cv::Mat(target.height, target.width, CV_32FC3, cv::Scalar::all(0)),
                 cv::Mat(target.height, target.width, CV_32F, cv::Scalar(0))};
  // Target pixel -> source pixel in one affine map of (u z, v z, z): R_s R_t^T K_t^-1, then K_s.
  const Eigen::Matrix3d target_to_source = source.R * target.R.transpose();
  const Eigen::Vector3d offset = source.t - target_to_source * target.t;
  const double x_max = source.width - 0.5, y_max = source.height - 0.5;
#pragma omp parallel for schedule(static)
  for (int i = 0; i < target.height; ++i) {
    const float* depth_row = target_depth.ptr<float>(i);
    cv::Vec3f* image_row = out.image.ptr<cv::Vec3f>(i);
    float* valid_row = out.valid.ptr<float>(i);
    for (int j = 0; j < target.width; ++j) {
      const double z = depth_row[j];
      if (!(z > 0)) continue;
      const Eigen::Vector3d ray((j + 0.5 - target.cx) / target.fx, (i + 0.5 - target.cy) / target.fy, 1.0);
      const Eigen::Vector3d p = target_to_source * (ray * z) + offset;
      if (!(p.z() > 1e-9)) continue;
      const double x = source.fx * p.x() / p.z() + source.cx, y = source.fy * p.y() / p.z() + source.cy;
      if (!(x >= 0.5 && x <= x_max && y >= 0.5 && y <= y_max)) continue;
      const float seen = depth_at(source_depth, x, y);
      if (!(seen > 0) || p.z() > seen * (1.0 + occlusion_tolerance)) continue;
      image_row[j] = colour_at(source_image, x, y);
      valid_row[j] = 1.0f;
    }
  }
  return out;
}

cv::Mat colour_variance(const std::vector<WarpedView>& warped, cv::Size size, cv::Mat* seen) {
  cv::Mat sum(size, CV_32FC3, cv::Scalar::all(0)), square(size, CV_32FC3, cv::Scalar::all(0));
  cv::Mat count(size, CV_32F, cv::Scalar(0));
  for (const auto& w : warped) {
    sum += w.image;
    square += w.image.mul(w.image);
    count += w.valid;
  }
  cv::Mat variance(size, CV_32F, cv::Scalar(0));
  *seen = cv::Mat(size, CV_32F, cv::Scalar(0));
  for (int i = 0; i < size.height; ++i) {
    const cv::Vec3f* m = sum.ptr<cv::Vec3f>(i);
    const cv::Vec3f* q = square.ptr<cv::Vec3f>(i);
    const float* n = count.ptr<float>(i);
    float* v = variance.ptr<float>(i);
    float* ok = seen->ptr<float>(i);
    for (int j = 0; j < size.width; ++j) {
      if (n[j] < 2) continue;
      float total = 0;
      for (int c = 0; c < 3; ++c) total += q[j][c] / n[j] - (m[j][c] / n[j]) * (m[j][c] / n[j]);
      v[j] = std::max(total / 3.0f, 0.0f);
      ok[j] = 1;
    }
  }
  return variance;
}

}  // namespace lrf::detail
