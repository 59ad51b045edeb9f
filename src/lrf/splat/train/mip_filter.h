#pragma once
// Mip-Splatting's 3D smoothing filter. Each Gaussian gets a filter of standard deviation
// sqrt(0.2) * d / f, where d / f is the finest world-space sampling interval any training camera has at
// that Gaussian (d: smallest depth among the cameras that see it, f: the largest focal length), i.e.
// a filter variance of 0.2 (d / f)^2 as in the Mip-Splatting code. The filter is convolved with the
// Gaussian: scale^2 -> scale^2 + filter^2, and opacity is multiplied by sqrt(det ratio) so that the
// integrated density is unchanged.
#include <vector>

#include <torch/types.h>

#include "lrf/scene/camera.h"

namespace lrf::splat {

// Filter standard deviation [N] for means [N, 3]. Gaussians that no camera sees get the largest
// value found; with no camera seeing anything, all get 0.
torch::Tensor compute_3d_filter(const torch::Tensor& means, const std::vector<Camera>& cameras);

struct FilteredGaussians {
  torch::Tensor log_scales;      // [N, 3] log sqrt(scale^2 + filter^2)
  torch::Tensor opacity_logits;  // [N, 1] logit(opacity * coef)
  torch::Tensor opacity_coef;    // [N, 1] sqrt(det(S^2) / det(S^2 + filter^2))
};

// Differentiable in log_scales and opacity_logits.
FilteredGaussians apply_3d_filter(const torch::Tensor& log_scales, const torch::Tensor& opacity_logits,
                                  const torch::Tensor& filter);
// The opacity factor alone (no autograd).
torch::Tensor filter_opacity_coef(const torch::Tensor& log_scales, const torch::Tensor& filter);

}  // namespace lrf::splat
