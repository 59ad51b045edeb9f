#include "lrf/nerf/scene_bounds.h"

#include <algorithm>
#include <cmath>

#include "lrf/core/error.h"

namespace lrf::nerf {
namespace {

// The q-quantile (q in [0, 1]) of values, by linear interpolation between order statistics.
double quantile(std::vector<double> values, double q) {
  std::sort(values.begin(), values.end());
  const double x = q * double(values.size() - 1);
  const size_t i = static_cast<size_t>(std::floor(x));
  const size_t j = std::min(i + 1, values.size() - 1);
  return values[i] + (x - double(i)) * (values[j] - values[i]);
}

bool finite(const Eigen::Vector3d& v) { return v.allFinite(); }

}  // namespace

Eigen::Vector3d SceneBounds::grid_coordinates(const Eigen::Vector3d& world) const {
  Eigen::Vector3d x = (world - center).cwiseQuotient(half);
  const double n = x.cwiseAbs().maxCoeff();
  if (n > 1.0) x *= (2.0 - 1.0 / n) / n;
  return ((x.array() + 2.0) / 4.0).cwiseMax(0.0).cwiseMin(1.0).matrix();
}

nlohmann::json SceneBounds::to_json() const {
  return {{"near", near},
          {"far", far},
          {"center", {center.x(), center.y(), center.z()}},
          {"half", {half.x(), half.y(), half.z()}},
          {"unit", unit}};
}

SceneBounds SceneBounds::from_json(const nlohmann::json& j, const std::string& path) {
  SceneBounds b;
  try {
    b.near = j.at("near").get<double>();
    b.far = j.at("far").get<double>();
    const auto c = j.at("center").get<std::vector<double>>(), h = j.at("half").get<std::vector<double>>();
    if (c.size() != 3 || h.size() != 3) fail(path, "scene bounds: \"center\" and \"half\" need 3 values each");
    b.center = Eigen::Vector3d(c[0], c[1], c[2]);
    b.half = Eigen::Vector3d(h[0], h[1], h[2]);
    b.unit = j.at("unit").get<double>();
  } catch (const nlohmann::json::exception& e) {
    fail(path, std::string("missing or bad scene bounds: ") + e.what());
  }
  if (!(std::isfinite(b.near) && std::isfinite(b.far) && b.near > 0 && b.far > b.near))
    fail(path, "scene bounds: need 0 < near < far, both finite");
  if (!finite(b.center) || !finite(b.half) || b.half.minCoeff() <= 0 || !std::isfinite(b.unit) || b.unit <= 0)
    fail(path, "scene bounds: the box needs a finite centre and positive half-sizes and unit");
  return b;
}

SceneBounds bounds_from_points(const std::vector<Camera>& cameras, const std::vector<Eigen::Vector3d>& points,
                               const Eigen::Vector3d& camera_mean, double camera_extent) {
  SceneBounds b;
  const double extent = camera_extent > 0 && std::isfinite(camera_extent) ? camera_extent : 1.0;
  std::vector<double> nears, fars;
  for (const auto& cam : cameras) {
    std::vector<double> depths;
    for (const auto& p : points) {
      Eigen::Vector2d pixel;
      double depth = 0;
      if (!cam.project(p, &pixel, &depth) || depth <= 0) continue;
      if (pixel.x() < 0 || pixel.y() < 0 || pixel.x() > cam.width || pixel.y() > cam.height) continue;
      depths.push_back(depth);
    }
    if (depths.size() < 10) continue;  // too few to tell this view's depth range
    nears.push_back(quantile(depths, 0.001));
    fars.push_back(quantile(depths, 0.999));
  }
  if (nears.empty()) {
    // No usable points: a sphere of the cameras' extent around their mean, seen from anywhere within it.
    b.near = 0.02 * extent;
    b.far = 3.0 * extent;
    b.center = camera_mean;
    b.half = Eigen::Vector3d::Constant(extent);
  } else {
    b.near = 0.9 * *std::min_element(nears.begin(), nears.end());
    b.far = 1.2 * *std::max_element(fars.begin(), fars.end());
    for (int a = 0; a < 3; ++a) {
      std::vector<double> coords;
      for (const auto& p : points) coords.push_back(p[a]);
      const double lo = quantile(coords, 0.02), hi = quantile(coords, 0.98);
      b.center[a] = 0.5 * (lo + hi);
      b.half[a] = 0.55 * (hi - lo);
    }
    // A flat box (points on a plane) would squash one axis into nothing: keep each side at least 5% of the largest.
    b.half = b.half.cwiseMax(0.05 * b.half.maxCoeff()).cwiseMax(1e-6 * extent);
  }
  b.unit = b.half.mean();
  return b;
}

}  // namespace lrf::nerf
