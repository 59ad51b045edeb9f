#include "lrf/points/far_shell.h"

#include <algorithm>
#include <cmath>

#include "lrf/core/error.h"

namespace lrf {
namespace {

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

Eigen::Vector3d median_point(const std::vector<SfmPoint>& points) {
  Eigen::Vector3d m;
  for (int a = 0; a < 3; ++a) {
    std::vector<double> c;
    for (const auto& p : points) c.push_back(p.xyz[a]);
    m[a] = percentile(c, 0.5);
  }
  return m;
}

}  // namespace

std::vector<SfmPoint> far_shell_points(const Scene& scene, const std::vector<SfmPoint>& points, const FarShellOptions& o) {
  if (o.points < 0) fail_usage("--far-shell must be >= 0");
  if (!(o.radius_factor >= 1)) fail_usage("--far-shell-radius must be >= 1 (the shell lies beyond the scene)");
  if (o.points == 0 || scene.train_indices.empty()) return {};
  const Eigen::Vector3d centre = points.empty() ? scene.camera_mean() : median_point(points);
  std::vector<double> distances;
  for (const auto& p : points) distances.push_back((p.xyz - centre).norm());
  double reach = percentile(distances, 0.97);
  for (const auto& v : scene.views) reach = std::max(reach, (v.camera.center() - centre).norm());
  const double radius = o.radius_factor * std::max(reach, 1e-6);

  std::vector<Eigen::Vector3d> sphere;
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int k = 0; k < o.points; ++k) {
    const double z = 1.0 - 2.0 * (k + 0.5) / o.points, r = std::sqrt(std::max(0.0, 1.0 - z * z));
    sphere.push_back(centre + radius * Eigen::Vector3d(r * std::cos(golden * k), r * std::sin(golden * k), z));
  }
  std::vector<Eigen::Vector3d> sum(sphere.size(), Eigen::Vector3d::Zero());
  std::vector<int> count(sphere.size(), 0);
  for (int i : scene.train_indices) {
    const Camera& cam = scene.views[static_cast<size_t>(i)].camera;
    cv::Mat image = scene.load_image_u8(i);
    for (size_t k = 0; k < sphere.size(); ++k) {
      Eigen::Vector2d px;
      if (!cam.project(sphere[k], &px)) continue;
      const int x = static_cast<int>(std::floor(px.x())), y = static_cast<int>(std::floor(px.y()));
      if (x < 0 || y < 0 || x >= image.cols || y >= image.rows) continue;
      const cv::Vec3b& c = image.at<cv::Vec3b>(y, x);
      sum[k] += Eigen::Vector3d(c[0], c[1], c[2]) / 255.0;
      ++count[k];
    }
  }
  std::vector<SfmPoint> shell;
  for (size_t k = 0; k < sphere.size(); ++k) {
    if (count[k] == 0) continue;  // no training view sees it: nothing to fit it to
    shell.push_back({sphere[k], (sum[k] / count[k]).cast<float>(), -1});
  }
  return shell;
}

}  // namespace lrf
