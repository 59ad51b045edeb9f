#include "lrf/splat/train/loss.h"

#include <cmath>

#include <ATen/ATen.h>

#include "lrf/splat/train/ssim_fused.h"

namespace lrf::splat {
namespace {

constexpr int kWindow = 11;
constexpr double kSigma = 1.5;

// 1D normalised Gaussian; the 2D window of 3DGS is its outer product, so filtering rows then columns
// is the same convolution at 22 instead of 121 multiplications per pixel.
torch::Tensor gaussian_1d() {
  auto x = torch::arange(kWindow, torch::kFloat64) - (kWindow / 2);
  auto g = torch::exp(-(x * x) / (2 * kSigma * kSigma));
  return (g / g.sum()).to(torch::kFloat32);
}

torch::Tensor blur(const torch::Tensor& x /*[B, M, H, W]*/) {
  static const torch::Tensor g32 = gaussian_1d();
  const torch::Tensor g = g32.to(x.scalar_type());
  const int64_t m = x.size(1);
  auto row = g.view({1, 1, 1, kWindow}).expand({m, 1, 1, kWindow}).contiguous();
  auto col = g.view({1, 1, kWindow, 1}).expand({m, 1, kWindow, 1}).contiguous();
  auto y = at::conv2d(x, row, torch::Tensor(), at::IntArrayRef{1, 1}, at::IntArrayRef{0, kWindow / 2}, at::IntArrayRef{1, 1}, m);
  return at::conv2d(y, col, torch::Tensor(), at::IntArrayRef{1, 1}, at::IntArrayRef{kWindow / 2, 0}, at::IntArrayRef{1, 1}, m);
}

}  // namespace

torch::Tensor ssim_map(const torch::Tensor& a_in, const torch::Tensor& b_in) {
  auto a = a_in.dim() == 3 ? a_in.unsqueeze(0) : a_in;
  auto b = b_in.dim() == 3 ? b_in.unsqueeze(0) : b_in;
  const int64_t c = a.size(1);
  // One grouped convolution for the five local statistics.
  auto stats = blur(torch::cat({a, b, a * a, b * b, a * b}, 1));
  auto parts = stats.split(c, 1);
  auto mu_a = parts[0], mu_b = parts[1];
  auto mu_a2 = mu_a * mu_a, mu_b2 = mu_b * mu_b, mu_ab = mu_a * mu_b;
  auto var_a = parts[2] - mu_a2, var_b = parts[3] - mu_b2, cov = parts[4] - mu_ab;
  constexpr double c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
  return ((2 * mu_ab + c1) * (2 * cov + c2)) / ((mu_a2 + mu_b2 + c1) * (var_a + var_b + c2));
}

torch::Tensor ssim(const torch::Tensor& a, const torch::Tensor& b) { return ssim_map(a, b).mean(); }

torch::Tensor photometric_loss(const torch::Tensor& rendered, const torch::Tensor& target, double lambda_ssim) {
  auto l1 = (rendered - target).abs().mean();
  if (lambda_ssim == 0) return l1;
  // Training takes the fused kernel (float32, gradient to the rendering only); the ATen version stays
  // for other types and as the tested reference of the formula.
  const bool fused = rendered.scalar_type() == torch::kFloat32 && target.scalar_type() == torch::kFloat32 &&
                     !target.requires_grad();
  auto s = fused ? fused_ssim(rendered, target) : ssim(rendered, target);
  return (1.0 - lambda_ssim) * l1 + lambda_ssim * (1.0 - s);
}

double psnr(const torch::Tensor& a, const torch::Tensor& b) {
  auto mse = (a.detach().clamp(0, 1).to(torch::kFloat64) - b.detach().clamp(0, 1).to(torch::kFloat64))
                 .pow(2)
                 .mean()
                 .item<double>();
  return -10.0 * std::log10(std::max(mse, 1e-20));
}

}  // namespace lrf::splat
