#include "lrf/align/correspondence_loss.h"

#include <cmath>

#include <ATen/ATen.h>

#include "lrf/core/error.h"

namespace lrf {

double absolute_pose_error(const Camera& ci, const Camera& cj) {
  Eigen::Matrix4d E = ci.camera_to_world().inverse() * cj.camera_to_world();
  return (E - Eigen::Matrix4d::Identity()).norm();  // Eigen's norm() of a matrix is Frobenius
}

std::vector<double> ape_weights(const std::vector<double>& apes) {
  double sum = 0;
  for (double a : apes) sum += a;
  std::vector<double> w(apes.size(), apes.empty() ? 0.0 : 1.0 / apes.size());
  if (sum > 0) {
    for (size_t k = 0; k < apes.size(); ++k) w[k] = apes[k] / sum;
  }
  return w;
}

torch::Tensor sample_latent_at_pixels(const torch::Tensor& latent, const torch::Tensor& pixels, int factor) {
  if (latent.dim() != 3) fail("sample_latent_at_pixels: latent must be [C, h, w]");
  const int64_t h = latent.size(1), w = latent.size(2);
  // Image pixel x (centre convention) -> latent continuous coordinate x / factor; latent sample k sits at
  // k + 0.5 there. grid_sample with align_corners=false maps [-1, 1] onto the outer edges of the samples.
  auto px = pixels.to(latent.scalar_type());
  auto gx = (px.select(1, 0) / factor) / w * 2 - 1;
  auto gy = (px.select(1, 1) / factor) / h * 2 - 1;
  auto grid = at::stack({gx, gy}, 1).view({1, 1, -1, 2});
  auto out = at::grid_sampler(latent.unsqueeze(0), grid, /*bilinear*/ 0, /*border*/ 1, /*align_corners*/ false);
  return out.view({latent.size(0), -1}).t();  // [M, C]
}

torch::Tensor correspondence_l1(const torch::Tensor& latent_i, const torch::Tensor& latent_j, const torch::Tensor& xi,
                                const torch::Tensor& xj, int factor) {
  return (sample_latent_at_pixels(latent_i, xi, factor) - sample_latent_at_pixels(latent_j, xj, factor)).abs().mean();
}

double high_frequency_energy_share(const torch::Tensor& latent) {
  auto z = latent.to(at::kDouble);
  z = z - z.mean({1, 2}, true);
  auto power = at::fft_fft2(z).abs().pow(2);  // [C, h, w]
  const int64_t h = z.size(1), w = z.size(2);
  auto fy = at::fft_fftfreq(h, 1.0, at::TensorOptions().dtype(at::kDouble)).abs().view({h, 1});
  auto fx = at::fft_fftfreq(w, 1.0, at::TensorOptions().dtype(at::kDouble)).abs().view({1, w});
  auto high = (at::maximum(fy.expand({h, w}), fx.expand({h, w})) > 0.25).to(at::kDouble);
  double total = power.sum().item<double>();
  if (total <= 0) return 0.0;
  return (power * high).sum().item<double>() / total;
}

}  // namespace lrf
