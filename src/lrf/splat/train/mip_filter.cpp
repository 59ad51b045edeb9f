#include "lrf/splat/train/mip_filter.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <ATen/ATen.h>
#include <ATen/Parallel.h>

namespace lrf::splat {

torch::Tensor compute_3d_filter(const torch::Tensor& means_in, const std::vector<Camera>& cameras) {
  auto means = means_in.detach().to(torch::kFloat64).contiguous();
  const int64_t n = means.size(0);
  const double* p = means.data_ptr<double>();
  double focal = 0;
  for (const auto& c : cameras) focal = std::max(focal, c.fx);
  std::vector<double> distance(static_cast<size_t>(n), std::numeric_limits<double>::infinity());
  at::parallel_for(0, n, 1024, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      const Eigen::Vector3d x(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
      double best = std::numeric_limits<double>::infinity();
      for (const auto& c : cameras) {
        const Eigen::Vector3d xc = c.R * x + c.t;
        if (xc.z() <= 0.2) continue;  // Mip-Splatting's depth threshold
        // Seen if it projects within the image widened by 15% on each side.
        const double u = xc.x() / xc.z() * c.fx + c.cx;
        const double v = xc.y() / xc.z() * c.fy + c.cy;
        if (u < -0.15 * c.width || u > 1.15 * c.width || v < -0.15 * c.height || v > 1.15 * c.height) continue;
        best = std::min(best, xc.z());
      }
      distance[static_cast<size_t>(i)] = best;
    }
  });
  double largest = 0;
  for (double d : distance)
    if (std::isfinite(d)) largest = std::max(largest, d);
  auto out = torch::empty({n}, torch::kFloat32);
  float* o = out.data_ptr<float>();
  const double k = focal > 0 ? std::sqrt(0.2) / focal : 0.0;
  for (int64_t i = 0; i < n; ++i) {
    const double d = std::isfinite(distance[static_cast<size_t>(i)]) ? distance[static_cast<size_t>(i)] : largest;
    o[i] = static_cast<float>(d * k);
  }
  return out;
}

FilteredGaussians apply_3d_filter(const torch::Tensor& log_scales, const torch::Tensor& opacity_logits,
                                  const torch::Tensor& filter) {
  auto s2 = torch::exp(2 * log_scales);
  auto f2 = (filter * filter).unsqueeze(1);
  auto total = s2 + f2;
  FilteredGaussians out;
  out.log_scales = 0.5 * torch::log(total);
  // sqrt(prod(s2) / prod(s2 + f2)) computed in log space: no underflow for tiny Gaussians.
  out.opacity_coef = torch::exp(0.5 * (2 * log_scales - torch::log(total)).sum(1, true));
  auto opacity = torch::sigmoid(opacity_logits) * out.opacity_coef;
  opacity = opacity.clamp(1e-7, 1 - 1e-7);
  out.opacity_logits = torch::log(opacity) - torch::log1p(-opacity);
  return out;
}

torch::Tensor filter_opacity_coef(const torch::Tensor& log_scales, const torch::Tensor& filter) {
  torch::NoGradGuard no_grad;
  auto ls = log_scales.detach();
  auto total = torch::exp(2 * ls) + (filter * filter).unsqueeze(1);
  return torch::exp(0.5 * (2 * ls - torch::log(total)).sum(1, true));
}

}  // namespace lrf::splat
