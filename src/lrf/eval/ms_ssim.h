#pragma once
// Multi-scale SSIM (Wang, Simoncelli & Bovik, 2003) as its authors' reference computes it: five scales,
// exponents 0.0448, 0.2856, 0.3001, 0.2363, 0.1333; at each scale the contrast-structure term, at the
// coarsest also the luminance term, each the mean over the valid (unpadded) positions of an 11x11
// Gaussian window (sigma 1.5); 2x2 average pooling between scales; C1 = (0.01 max)^2, C2 = (0.03 max)^2.
// Colour images are scored per channel and the channel values averaged. Negative terms (anti-correlated
// content) are clamped to 0, as common implementations do, so the product stays real. Higher is better.
#include <optional>

#include <torch/torch.h>

namespace lrf {

// The smallest image side MS-SSIM can score: the coarsest of its five scales must still hold a window.
constexpr int kMsSsimMinSide = 11 << 4;

// MS-SSIM of two [C, H, W] images, clamped to [0, max]. std::nullopt if a side is shorter than
// kMsSsimMinSide (fewer scales would be another metric); throws lrf::Error on mismatched shapes.
std::optional<double> ms_ssim(const torch::Tensor& a, const torch::Tensor& b, double max = 1.0);

}  // namespace lrf
