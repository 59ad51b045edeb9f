#include "lrf/camera_path/pose_math.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "lrf/core/error.h"

namespace lrf::camera_path {

Camera look_at(const Camera& intrinsics, const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
               const Eigen::Vector3d& up) {
  const Eigen::Vector3d view = target - eye;
  if (!(view.norm() > 1e-12)) fail("camera path: a camera's target coincides with its position");
  const Eigen::Vector3d z = view.normalized();
  // With y pointing down, x = z x up: for z = +z and up = -y (OpenCV's own world) this gives x = +x.
  const Eigen::Vector3d x_raw = z.cross(up);
  if (!(x_raw.norm() > 1e-9 * up.norm())) fail("camera path: the up direction is parallel to a camera's view");
  const Eigen::Vector3d x = x_raw.normalized();
  const Eigen::Vector3d y = z.cross(x);
  Camera c = intrinsics;
  c.R.row(0) = x.transpose();
  c.R.row(1) = y.transpose();
  c.R.row(2) = z.transpose();
  c.t = -c.R * eye;
  return c;
}

MeanPose mean_pose(const std::vector<Camera>& cameras) {
  if (cameras.empty()) fail("camera path: no cameras to average");
  Eigen::Vector3d center = Eigen::Vector3d::Zero(), forward = Eigen::Vector3d::Zero(), up = Eigen::Vector3d::Zero();
  for (const auto& c : cameras) {
    center += c.center();
    forward += camera_forward(c);
    up -= camera_down(c);
  }
  center /= double(cameras.size());
  if (forward.norm() < 1e-6 * double(cameras.size()))
    fail("camera path: the cameras look in opposite directions; their mean viewing direction is undefined");
  const Camera mean = look_at(cameras.front(), center, center + forward.normalized(), up);
  return {center, camera_right(mean), camera_down(mean), camera_forward(mean)};
}

bool axes_convergence_point(const std::vector<Camera>& cameras, Eigen::Vector3d* point) {
  // Minimise sum_i |(I - d_i d_i^T)(p - c_i)|^2: the normal equations are A p = b with A = sum (I - d d^T).
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const auto& c : cameras) {
    const Eigen::Vector3d d = camera_forward(c);
    const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - d * d.transpose();
    A += P;
    b += P * c.center();
  }
  if (cameras.size() < 2) return false;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(A);
  // A's eigenvalues lie in [0, n]; parallel axes leave one near 0 (the common direction is free). Below
  // 2% of n the point slides along that direction with the axes' noise: call it undefined.
  if (eig.eigenvalues().minCoeff() < 0.02 * double(cameras.size())) return false;
  *point = A.ldlt().solve(b);
  return point->allFinite();
}

double quantile(std::vector<double> values, double q) {
  if (values.empty()) fail("camera path: quantile of no values");
  std::sort(values.begin(), values.end());
  const double pos = std::clamp(q, 0.0, 1.0) * double(values.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(pos));
  const size_t hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (pos - double(lo)) * (values[hi] - values[lo]);
}

}  // namespace lrf::camera_path
