// One turn around an object: the orbit's centre is the median of the SfM points (the cameras' axes'
// meeting point, or their mean, when there are none), its axis the cameras' mean up direction, its
// height and radius the cameras' mean height above and distance from that centre. It starts at the first
// training camera's bearing, so the first frame resembles a training view.
#include <algorithm>
#include <cmath>

#include "lrf/camera_path/camera_path.h"
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

std::vector<Camera> orbit_path(const std::vector<Camera>& cameras, const std::vector<Eigen::Vector3d>& points,
                               const PathOptions& options, PathGeometry* geometry) {
  if (cameras.empty()) fail("camera path: no cameras to orbit with");
  Eigen::Vector3d up = Eigen::Vector3d::Zero();
  for (const auto& c : cameras) up -= camera_down(c);
  if (up.norm() < 1e-6 * double(cameras.size())) fail("camera path: the cameras' up directions cancel out; no orbit axis");
  up.normalize();
  std::string source;
  const Eigen::Vector3d center = orbit_center(cameras, points, &source);
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
