#pragma once
// A deliberately simple float64 renderer with the same conventions as the fast rasterizer: no tiles, no
// boxes, no per-thread anything; every pixel walks every Gaussian in depth order. Tests compare the fast
// kernels against it and take finite differences of it. It is slow: small scenes only.
#include <torch/torch.h>

#include <cstdint>

#include "lrf/splat/raster/rasterize.h"

namespace lrf::splat {

struct ReferenceOutput {
  torch::Tensor image;  // [C,H,W] float64
  torch::Tensor alpha;  // [1,H,W] float64
  torch::Tensor depth;  // [1,H,W] float64
  torch::Tensor xy;     // [N,2]  float64 projected means (pixels)
  torch::Tensor radii;  // [N]    int32
  // A hash of every discrete decision taken (culling, Jacobian clamps, SH clamps, and per pixel and Gaussian:
  // outside the tile rectangle, α below 1/255, α clamped, termination). Two renders with equal hashes lie
  // on the same smooth piece of the image as a function of the inputs, which is what finite differences need.
  uint64_t decisions = 0;
};

// Inputs as for render() (any floating dtype; computed in float64). xy_offset [N,2], when defined, is added
// to the projected means (pixels): finite differences in it give the screen-space gradient.
ReferenceOutput render_reference(const torch::Tensor& means, const torch::Tensor& log_scales,
                                 const torch::Tensor& quats, const torch::Tensor& opacity_logits,
                                 const torch::Tensor& sh, const RasterSettings& s,
                                 const torch::Tensor& xy_offset = {});

}  // namespace lrf::splat
