#pragma once
// Mean SSIM (3DGS constants, 11x11 Gaussian window sigma 1.5, zero padding, per channel) as one fused
// autograd function over raw arrays: five separable blurs forward, three backward, no temporaries
// per statistic. Gradient flows to `a` only (the rendering); `b` is the target.
#include <torch/types.h>

namespace lrf::splat {

// a, b: [C, H, W] or [B, C, H, W] float32, same shape. Returns a 0-dim tensor.
torch::Tensor fused_ssim(const torch::Tensor& a, const torch::Tensor& b);

}  // namespace lrf::splat
