// One turn around an object: the orbit's centre is the median of the SfM points (the cameras' axes'
// meeting point, or their mean, when there are none), its axis the cameras' mean up direction (or the
// normal of the plane their centres lie in, see orbit_axis), its height and radius the cameras' mean height
// above and distance from that centre. It starts at the first training camera's bearing, so the first frame
// resembles a training view.
#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "lrf/camera_path/orbit_path.h"
#include "lrf/camera_path/pose_math.h"
#include "lrf/core/error.h"

namespace lrf::camera_path {

Eigen::Vector3d orbit_center(const std::vector<Camera>& cameras, const std::vector<Eigen::Vector3d>& points,
                             std::string* source) {
  if (points.size() >= 10) {
    // Coordinate-wise median: the object's bulk, unmoved by far background points.
    Eigen::Vector3d c;
    for (int a = 0; a < 3; ++a) {
      std::vector<double> v;
      v.reserve(points.size());
      for (const auto& p : points) v.push_back(p[a]);
      c[a] = quantile(v, 0.5);
    }
    if (c.allFinite()) {
      *source = "median of the SfM points";
      return c;
    }
  }
  Eigen::Vector3d p;
  if (axes_convergence_point(cameras, &p)) {
    *source = "where the cameras' axes meet";
    return p;
  }
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& c : cameras) mean += c.center();
  *source = "mean of the camera centres";
  return mean / double(cameras.size());
}

namespace {

// The orbit's axis. The cameras' mean up direction is the natural one, but photos taken with the camera on
// its side (a hand-held walk around an object, shot in portrait and stored as landscape: ../shared's
// tumbler) have their up directions lying in the ring they were taken from, and an orbit about that axis
// cuts through the table. So when the camera centres lie close to a plane (their least spread under
// half the next one, as on a ring or a cap around the object) and the mean up direction is more than 30
// degrees off that plane's normal, or cancels out, the normal is the axis: on the side of the mean up
// direction when it leans one way, else on the cameras' side of the centre (they look down on the object).
Eigen::Vector3d orbit_axis(const std::vector<Camera>& cameras, const Eigen::Vector3d& center) {
  Eigen::Vector3d up = Eigen::Vector3d::Zero();
  for (const auto& c : cameras) up -= camera_down(c);
  const bool up_cancels = up.norm() < 1e-6 * double(cameras.size());
  if (!up_cancels) up.normalize();
  if (cameras.size() >= 4) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const auto& c : cameras) mean += c.center();
    mean /= double(cameras.size());
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const auto& c : cameras) cov += (c.center() - mean) * (c.center() - mean).transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
    const Eigen::Vector3d spread = eig.eigenvalues().cwiseMax(0.0).cwiseSqrt();  // ascending
    const bool planar = spread[1] > 0 && spread[0] < 0.5 * spread[1];
    Eigen::Vector3d normal = eig.eigenvectors().col(0).normalized();
    if (planar && (up_cancels || std::abs(normal.dot(up)) < std::cos(M_PI / 6))) {
      double side = up_cancels ? 0.0 : normal.dot(up);
      if (std::abs(side) < 0.1) side = normal.dot(mean - center);
      return side < 0 ? Eigen::Vector3d(-normal) : normal;
    }
  }
  if (up_cancels) fail("camera path: the cameras' up directions cancel out; no orbit axis");
  return up;
}

}  // namespace

std::vector<Camera> orbit_path(const std::vector<Camera>& cameras, const std::vector<Eigen::Vector3d>& points,
                               const PathOptions& options, PathGeometry* geometry) {
  if (cameras.empty()) fail("camera path: no cameras to orbit with");
  std::string source;
  const Eigen::Vector3d center = orbit_center(cameras, points, &source);
  const Eigen::Vector3d up = orbit_axis(cameras, center);
  double height = 0, radius = 0;
  for (const auto& c : cameras) {
    const Eigen::Vector3d d = c.center() - center;
    height += up.dot(d);
    radius += (d - up.dot(d) * up).norm();
  }
  height /= double(cameras.size());
  radius /= double(cameras.size());
  if (!(radius > 1e-9 * (1.0 + std::abs(height))))
    fail("camera path: the cameras sit on the orbit's axis (no horizontal distance from its centre); use --path spiral");
  // The first camera's bearing, or any direction perpendicular to the axis when it sits on the axis.
  Eigen::Vector3d d0 = cameras.front().center() - center;
  Eigen::Vector3d a = d0 - up.dot(d0) * up;
  if (a.norm() < 1e-9 * radius) a = up.unitOrthogonal();
  a.normalize();
  const Eigen::Vector3d b = up.cross(a);
  std::vector<Camera> path;
  const int n = options.frames;
  for (int k = 0; k < n; ++k) {
    const double phi = 2.0 * M_PI * double(k) / double(n);
    const Eigen::Vector3d eye = center + height * up + radius * (std::cos(phi) * a + std::sin(phi) * b);
    path.push_back(look_at(cameras.front(), eye, center, up));
  }
  if (geometry) *geometry = {center, center, up, Eigen::Vector3d(radius, radius, height), source};
  return path;
}

}  // namespace lrf::camera_path
