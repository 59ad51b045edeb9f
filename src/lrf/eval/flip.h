#pragma once
// FLIP (Andersson et al., "FLIP: A Difference Evaluator for Alternating Images", HPG 2020), the LDR
// variant: a perceptual difference of two sRGB images as a viewer sees them flipping between the two, in
// [0, 1] (0 = identical; lower is better). It needs no learned weights, which is why lrf reports it
// beside PSNR/SSIM: those two favour blur, FLIP also punishes lost edges and points.
//
// As published: both images go to the opponent space YCxCz, are filtered by the contrast sensitivity of
// the eye at `pixels_per_degree`, and compared as Hunt-adjusted L*a*b* colours by the HyAB distance; an
// edge and point detector on the luminance raises the error where features differ. The value is the mean
// of the per-pixel error map. Filters reflect at the image border (the published code's "symmetric").
#include <torch/torch.h>

namespace lrf {

// The published default viewing condition: a 0.7 m wide, 3840-pixel monitor seen from 0.7 m.
double flip_default_pixels_per_degree();

// Per-pixel FLIP error map [H, W] (float64) of `test` against `reference`: [3, H, W] sRGB images in
// [0, 1] (clamped first). Throws lrf::Error on mismatched or non-RGB shapes.
torch::Tensor flip_map(const torch::Tensor& reference, const torch::Tensor& test,
                       double pixels_per_degree = flip_default_pixels_per_degree());
// The mean of flip_map.
double flip(const torch::Tensor& reference, const torch::Tensor& test,
            double pixels_per_degree = flip_default_pixels_per_degree());

}  // namespace lrf
