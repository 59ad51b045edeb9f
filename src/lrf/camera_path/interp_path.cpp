// A smooth path through the training views in their order: centres on a uniform Catmull-Rom spline
// (which passes through every centre with a continuous tangent), orientations slerped between
// neighbouring views, intrinsics interpolated linearly.
#include <algorithm>
#include <cmath>

#include "lrf/camera_path/interp_path.h"
#include "lrf/core/error.h"

namespace lrf::camera_path {
namespace {

Eigen::Vector3d catmull_rom(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& p2,
                            const Eigen::Vector3d& p3, double t) {
  const double t2 = t * t, t3 = t2 * t;
  return 0.5 * (2.0 * p1 + (p2 - p0) * t + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * t2 +
                (-p0 + 3.0 * p1 - 3.0 * p2 + p3) * t3);
}

}  // namespace

std::vector<Camera> interp_path(const std::vector<Camera>& cameras, const PathOptions& options) {
  if (cameras.empty()) fail("camera path: no views to interpolate");
  const int n = options.frames;
  const int k = static_cast<int>(cameras.size());
  if (k == 1) return std::vector<Camera>(static_cast<size_t>(n), cameras.front());
  const Camera& first = cameras.front();
  // Every view at the first one's image size, so that intrinsics can be blended.
  std::vector<Camera> views;
  for (const auto& c : cameras)
    views.push_back(c.width == first.width && c.height == first.height ? c : c.resized(first.width, first.height));
  auto centre = [&](int i) -> Eigen::Vector3d {
    // Reflected end points give the spline's first and last segments a natural tangent.
    if (i < 0) return 2.0 * views[0].center() - views[1].center();
    if (i >= k) return 2.0 * views[static_cast<size_t>(k - 1)].center() - views[static_cast<size_t>(k - 2)].center();
    return views[static_cast<size_t>(i)].center();
  };
  std::vector<Camera> path;
  for (int j = 0; j < n; ++j) {
    const double s = n == 1 ? 0.0 : double(j) * double(k - 1) / double(n - 1);
    const int seg = std::min(static_cast<int>(std::floor(s)), k - 2);
    const double t = s - seg;
    const Camera& a = views[static_cast<size_t>(seg)];
    const Camera& b = views[static_cast<size_t>(seg + 1)];
    const Eigen::Vector3d eye = catmull_rom(centre(seg - 1), centre(seg), centre(seg + 1), centre(seg + 2), t);
    // Eigen's slerp takes the shorter arc (it flips the sign of one quaternion when their dot is negative).
    const Eigen::Quaterniond qa(a.R), qb(b.R);
    Camera c = a;
    c.R = qa.slerp(t, qb).normalized().toRotationMatrix();
    c.t = -c.R * eye;
    c.fx = (1 - t) * a.fx + t * b.fx;
    c.fy = (1 - t) * a.fy + t * b.fy;
    c.cx = (1 - t) * a.cx + t * b.cx;
    c.cy = (1 - t) * a.cy + t * b.cy;
    path.push_back(c);
  }
  return path;
}

}  // namespace lrf::camera_path
