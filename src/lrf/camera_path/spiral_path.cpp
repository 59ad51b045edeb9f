// LLFF's forward-facing spiral (Mildenhall et al. 2019), in lrf's camera convention: the cameras circle
// the mean training pose in its image plane, move back and forth along its axis, and keep looking at a
// focus point at the scene's depth.
#include <cmath>

#include "lrf/camera_path/spiral_path.h"
#include "lrf/camera_path/pose_math.h"
#include "lrf/core/error.h"

namespace lrf::camera_path {
namespace {

// The focus distance along the mean viewing direction. LLFF takes the near and far bounds of the scene
// (0.9x the nearest and 5x the farthest point depth) and blends their inverses, so that the focus sits
// nearer the front of the scene; the nearest and farthest are the 1% and 99% depth quantiles here, so
// that a few stray points do not move it.
double focus_depth(const MeanPose& mean, const std::vector<Camera>& cameras,
                   const std::vector<Eigen::Vector3d>& points, const SpiralOptions& o, std::string* source) {
  std::vector<double> depths;
  for (const auto& p : points) {
    const double d = mean.forward.dot(p - mean.center);
    if (d > 0 && std::isfinite(d)) depths.push_back(d);
  }
  if (depths.size() >= 10) {
    const double near = 0.9 * quantile(depths, 0.01), far = 5.0 * quantile(depths, 0.99);
    *source = "SfM points' depths";
    return 1.0 / ((1.0 - o.focus_blend) / near + o.focus_blend / far);
  }
  Eigen::Vector3d p;
  if (axes_convergence_point(cameras, &p) && mean.forward.dot(p - mean.center) > 0) {
    *source = "the cameras' axes";
    return mean.forward.dot(p - mean.center);
  }
  // Neither points nor converging axes: a depth well beyond the cameras' spread.
  double spread = 0;
  for (const auto& c : cameras) spread = std::max(spread, (c.center() - mean.center).norm());
  if (!(spread > 0)) fail("camera path: the scene has no points in front of the cameras and a single camera position; "
                          "the spiral's focus is undefined");
  *source = "10x the cameras' spread (no points in front of the cameras)";
  return 10.0 * spread;
}

}  // namespace

std::vector<Camera> spiral_path(const std::vector<Camera>& cameras, const std::vector<Eigen::Vector3d>& points,
                                const PathOptions& options, PathGeometry* geometry) {
  const MeanPose mean = mean_pose(cameras);
  std::string source;
  const double focus = focus_depth(mean, cameras, points, options.spiral, &source);
  std::vector<double> dx, dy, dz;
  for (const auto& c : cameras) {
    const Eigen::Vector3d d = c.center() - mean.center;
    dx.push_back(std::abs(mean.right.dot(d)));
    dy.push_back(std::abs(mean.down.dot(d)));
    dz.push_back(std::abs(mean.forward.dot(d)));
  }
  const double q = options.spiral.radius_quantile;
  const Eigen::Vector3d radii(quantile(dx, q), quantile(dy, q), quantile(dz, q));
  const Eigen::Vector3d target = mean.center + focus * mean.forward;
  const Eigen::Vector3d up = -mean.down;
  std::vector<Camera> path;
  const int n = options.frames;
  for (int k = 0; k < n; ++k) {
    const double theta = 2.0 * M_PI * options.spiral.rotations * double(k) / double(n);
    const Eigen::Vector3d eye = mean.center + radii.x() * std::cos(theta) * mean.right +
                                radii.y() * std::sin(theta) * mean.down +
                                radii.z() * std::sin(options.spiral.z_rate * theta) * mean.forward;
    path.push_back(look_at(cameras.front(), eye, target, up));
  }
  if (geometry) *geometry = {mean.center, target, up, radii, source};
  return path;
}

}  // namespace lrf::camera_path
