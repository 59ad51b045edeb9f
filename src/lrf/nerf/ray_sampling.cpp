#include "lrf/nerf/ray_sampling.h"

#include <algorithm>
#include <cmath>

namespace lrf::nerf {

void pixel_ray(const Camera& camera, int x, int y, double* origin, double* direction) {
  const Eigen::Vector3d in_camera((x + 0.5 - camera.cx) / camera.fx, (y + 0.5 - camera.cy) / camera.fy, 1.0);
  const Eigen::Vector3d d = camera.R.transpose() * in_camera;
  const Eigen::Vector3d o = camera.center();
  for (int a = 0; a < 3; ++a) {
    origin[a] = o[a];
    direction[a] = d[a];
  }
}

void camera_rays(const Camera& camera, std::vector<double>* origins, std::vector<double>* directions) {
  const size_t n = static_cast<size_t>(camera.width) * static_cast<size_t>(camera.height);
  origins->resize(3 * n);
  directions->resize(3 * n);
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x) {
      const size_t k = static_cast<size_t>(y) * static_cast<size_t>(camera.width) + static_cast<size_t>(x);
      pixel_ray(camera, x, y, origins->data() + 3 * k, directions->data() + 3 * k);
    }
}

double depth_at(const SceneBounds& bounds, double s) { return 1.0 / ((1.0 - s) / bounds.near + s / bounds.far); }

void stratified_samples(int n, const float* jitter, float* s) {
  for (int i = 0; i < n; ++i) s[i] = (float(i) + (jitter ? jitter[i] : 0.5f)) / float(n);
}

void importance_samples(const float* coarse_weights, int n_coarse, int n_fine, const float* jitter, float* s) {
  double total = 0.0;
  for (int i = 0; i < n_coarse; ++i) total += std::max(0.0f, coarse_weights[i]);
  // 1% of the mass (or all of it, for a ray that saw nothing) spread evenly over the bins.
  const double floor_mass = total > 1e-12 ? 0.01 * total / n_coarse : 1.0 / n_coarse;
  std::vector<double> cdf(static_cast<size_t>(n_coarse) + 1, 0.0);
  for (int i = 0; i < n_coarse; ++i)
    cdf[static_cast<size_t>(i) + 1] = cdf[static_cast<size_t>(i)] + std::max(0.0f, coarse_weights[i]) + floor_mass;
  const double sum = cdf.back();
  int bin = 0;
  for (int k = 0; k < n_fine; ++k) {
    const double u = (double(k) + (jitter ? jitter[k] : 0.5)) / n_fine * sum;  // increasing in k
    while (bin < n_coarse - 1 && cdf[static_cast<size_t>(bin) + 1] <= u) ++bin;
    const double lo = cdf[static_cast<size_t>(bin)], hi = cdf[static_cast<size_t>(bin) + 1];
    const double t = hi > lo ? std::clamp((u - lo) / (hi - lo), 0.0, 1.0) : 0.5;
    s[k] = static_cast<float>((bin + t) / n_coarse);
  }
}

void sample_points(const SceneBounds& bounds, const double* origin, const double* direction, const float* s, int n,
                   float* grid_points, float* delta) {
  const Eigen::Vector3d o(origin[0], origin[1], origin[2]), d(direction[0], direction[1], direction[2]);
  const double length = d.norm() / bounds.unit;
  double z = depth_at(bounds, s[0]);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d g = bounds.grid_coordinates(o + z * d);
    for (int a = 0; a < 3; ++a) grid_points[3 * i + a] = static_cast<float>(g[a]);
    if (i + 1 < n) {
      const double z_next = depth_at(bounds, s[i + 1]);
      delta[i] = static_cast<float>((z_next - z) * length);
      z = z_next;
    } else {
      delta[i] = kLastInterval;
    }
  }
}

}  // namespace lrf::nerf
