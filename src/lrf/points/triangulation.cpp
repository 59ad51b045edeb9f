#include "lrf/points/triangulation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include <Eigen/Dense>

namespace lrf {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Depth of the point in front of the camera (<= 0: behind it).
double depth_in(const Camera& c, const Eigen::Vector3d& p) { return (c.R * p + c.t).z(); }

// Observations of the point kept as inliers: within max_error_px, in front of the camera, one per view.
std::vector<PixelObservation> agreeing(const std::vector<Camera>& cameras, const std::vector<PixelObservation>& obs,
                                       const Eigen::Vector3d& p, double max_error_px, double* error_sum) {
  std::vector<std::pair<double, size_t>> best;  // per view: (error, observation)
  std::vector<int> slot(cameras.size(), -1);
  for (size_t k = 0; k < obs.size(); ++k) {
    double e = reprojection_error(cameras[static_cast<size_t>(obs[k].view)], p, obs[k].pixel);
    if (!(e <= max_error_px)) continue;
    int& s = slot[static_cast<size_t>(obs[k].view)];
    if (s < 0) {
      s = static_cast<int>(best.size());
      best.emplace_back(e, k);
    } else if (e < best[static_cast<size_t>(s)].first) {
      best[static_cast<size_t>(s)] = {e, k};
    }
  }
  std::vector<PixelObservation> out;
  *error_sum = 0;
  for (const auto& [e, k] : best) {
    out.push_back(obs[k]);
    *error_sum += e;
  }
  return out;
}

}  // namespace

bool triangulate_linear(const std::vector<Camera>& cameras, const std::vector<PixelObservation>& obs,
                        Eigen::Vector3d* point) {
  if (obs.size() < 2) return false;
  Eigen::MatrixXd A(2 * obs.size(), 4);
  for (size_t k = 0; k < obs.size(); ++k) {
    const Camera& c = cameras[static_cast<size_t>(obs[k].view)];
    // Normalised coordinates keep the system's rows on the same scale whatever the focal length.
    const double u = (obs[k].pixel.x() - c.cx) / c.fx, v = (obs[k].pixel.y() - c.cy) / c.fy;
    Eigen::Matrix<double, 3, 4> P;
    P << c.R, c.t;
    A.row(2 * k) = u * P.row(2) - P.row(0);
    A.row(2 * k + 1) = v * P.row(2) - P.row(1);
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullV);
  Eigen::Vector4d X = svd.matrixV().col(3);
  const auto& s = svd.singularValues();
  // Rank < 3 (e.g. every ray through the same camera centre): no unique point.
  if (!(s(2) > 1e-12 * std::max(s(0), 1e-300))) return false;
  if (!(std::abs(X(3)) > 1e-12 * X.head<3>().norm())) return false;
  *point = X.head<3>() / X(3);
  return point->allFinite();
}

double reprojection_error(const Camera& camera, const Eigen::Vector3d& point, const Eigen::Vector2d& pixel) {
  Eigen::Vector2d px;
  if (!camera.project(point, &px)) return kInf;
  return (px - pixel).norm();
}

void refine_point(const std::vector<Camera>& cameras, const std::vector<PixelObservation>& obs, Eigen::Vector3d* point,
                  int iterations) {
  Eigen::Vector3d X = *point;
  for (int it = 0; it < iterations; ++it) {
    Eigen::Matrix3d JtJ = Eigen::Matrix3d::Zero();
    Eigen::Vector3d Jtr = Eigen::Vector3d::Zero();
    double cost = 0;
    for (const auto& o : obs) {
      const Camera& c = cameras[static_cast<size_t>(o.view)];
      Eigen::Vector3d q = c.R * X + c.t;
      if (q.z() <= 1e-12) return;  // left the cameras' front: keep the last good estimate
      const double iz = 1.0 / q.z();
      Eigen::Vector2d r(c.fx * q.x() * iz + c.cx - o.pixel.x(), c.fy * q.y() * iz + c.cy - o.pixel.y());
      Eigen::Matrix<double, 2, 3> dq;
      dq << c.fx * iz, 0, -c.fx * q.x() * iz * iz, 0, c.fy * iz, -c.fy * q.y() * iz * iz;
      Eigen::Matrix<double, 2, 3> J = dq * c.R;
      JtJ += J.transpose() * J;
      Jtr += J.transpose() * r;
      cost += r.squaredNorm();
    }
    // A small damping keeps the step finite when the rays are nearly parallel.
    JtJ.diagonal().array() += 1e-9 * std::max(JtJ.diagonal().maxCoeff(), 1e-12);
    Eigen::Vector3d step = JtJ.ldlt().solve(-Jtr);
    if (!step.allFinite()) return;
    Eigen::Vector3d next = X + step;
    double next_cost = 0;
    for (const auto& o : obs) {
      double e = reprojection_error(cameras[static_cast<size_t>(o.view)], next, o.pixel);
      next_cost += e * e;
    }
    if (!(next_cost < cost)) break;
    X = next;
    if (step.norm() < 1e-12 * (1 + X.norm())) break;
  }
  *point = X;
}

double max_triangulation_angle_deg(const std::vector<Camera>& cameras, const std::vector<PixelObservation>& obs,
                                   const Eigen::Vector3d& point) {
  std::vector<Eigen::Vector3d> rays;
  for (const auto& o : obs) rays.push_back((point - cameras[static_cast<size_t>(o.view)].center()).normalized());
  double min_cos = 1;
  for (size_t a = 0; a < rays.size(); ++a)
    for (size_t b = a + 1; b < rays.size(); ++b) min_cos = std::min(min_cos, rays[a].dot(rays[b]));
  return std::acos(std::clamp(min_cos, -1.0, 1.0)) * 180.0 / M_PI;
}

bool triangulate_robust(const std::vector<Camera>& cameras, const std::vector<PixelObservation>& obs,
                        const RobustTriangulationOptions& o, RobustPoint* out) {
  std::vector<std::pair<size_t, size_t>> pairs;
  const size_t n = obs.size();
  if (n * (n - 1) / 2 <= static_cast<size_t>(std::max(o.max_seed_pairs, 1))) {
    for (size_t a = 0; a < n; ++a)
      for (size_t b = a + 1; b < n; ++b)
        if (obs[a].view != obs[b].view) pairs.emplace_back(a, b);
  } else {
    // Long tracks (often chained wrong matches): a seeded sample of pairs, never the n^2 list.
    std::mt19937_64 rng(o.seed);
    std::uniform_int_distribution<size_t> pick(0, n - 1);
    for (int k = 0; k < 4 * o.max_seed_pairs && static_cast<int>(pairs.size()) < o.max_seed_pairs; ++k) {
      size_t a = pick(rng), b = pick(rng);
      if (obs[a].view != obs[b].view) pairs.emplace_back(std::min(a, b), std::max(a, b));
    }
  }
  if (pairs.empty()) return false;
  std::vector<PixelObservation> best;
  double best_error = kInf;
  for (auto [a, b] : pairs) {
    std::vector<PixelObservation> two = {obs[a], obs[b]};
    Eigen::Vector3d X;
    if (!triangulate_linear(cameras, two, &X)) continue;
    if (depth_in(cameras[static_cast<size_t>(obs[a].view)], X) <= 0 || depth_in(cameras[static_cast<size_t>(obs[b].view)], X) <= 0) continue;
    if (max_triangulation_angle_deg(cameras, two, X) < o.min_angle_deg) continue;
    double error = 0;
    auto inliers = agreeing(cameras, obs, X, o.max_error_px, &error);
    if (inliers.size() > best.size() || (inliers.size() == best.size() && error < best_error)) {
      best = std::move(inliers);
      best_error = error;
    }
  }
  if (best.size() < 2) return false;
  // Re-solve on every agreeing observation, refine, and take the agreeing set once more.
  Eigen::Vector3d X;
  if (!triangulate_linear(cameras, best, &X)) return false;
  refine_point(cameras, best, &X);
  double error = 0;
  auto inliers = agreeing(cameras, obs, X, o.max_error_px, &error);
  if (inliers.size() < 2) return false;
  if (inliers.size() != best.size()) {
    refine_point(cameras, inliers, &X);
    inliers = agreeing(cameras, obs, X, o.max_error_px, &error);
  }
  if (inliers.size() < 2) return false;
  out->xyz = X;
  out->inliers = std::move(inliers);
  out->mean_error_px = error / out->inliers.size();
  out->angle_deg = max_triangulation_angle_deg(cameras, out->inliers, X);
  return true;
}

}  // namespace lrf
