#pragma once
// Photometric losses of 3DGS, for any channel count: L1, SSIM with an 11x11 Gaussian window
// (sigma 1.5, zero padding, C1 = 0.01^2, C2 = 0.03^2, each channel on its own), and their mix.
#include <torch/types.h>

namespace lrf::splat {

// Mean SSIM of two images [C, H, W] (or [B, C, H, W]); differentiable.
torch::Tensor ssim(const torch::Tensor& a, const torch::Tensor& b);
// Per-pixel SSIM map [B, C, H, W].
torch::Tensor ssim_map(const torch::Tensor& a, const torch::Tensor& b);
// (1 - lambda) * L1 + lambda * (1 - SSIM); 3DGS uses lambda = 0.2.
torch::Tensor photometric_loss(const torch::Tensor& rendered, const torch::Tensor& target,
                               double lambda_ssim = 0.2);
// PSNR in dB of images in [0, 1] (both clamped to [0, 1] first).
double psnr(const torch::Tensor& a, const torch::Tensor& b);

}  // namespace lrf::splat
