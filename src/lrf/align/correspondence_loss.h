#pragma once
// Stage I's correspondence term: latents of two views sampled bilinearly at corresponding pixels
// (pixel / 8 in latent coordinates) should agree, weighted per view pair by the pair's absolute pose
// error (APE) share, as the paper's appendix defines it.
#include <vector>

#include <Eigen/Core>
#include <torch/types.h>

#include "lrf/scene/camera.h"

namespace lrf {

// APE_ij = ||P_i^-1 P_j - I||_F with P the 4x4 camera-to-world poses.
double absolute_pose_error(const Camera& ci, const Camera& cj);
// lambda_ij = APE_ij / sum_k APE_k over the pairs of one step; uniform if every APE is zero.
std::vector<double> ape_weights(const std::vector<double>& apes);

// Samples latent [C, h, w] at image pixel coordinates [M, 2] (x, y; pixel centres at +0.5 of an image
// `factor` times larger): returns [M, C]. Bilinear, border-clamped, differentiable w.r.t. the latent.
torch::Tensor sample_latent_at_pixels(const torch::Tensor& latent, const torch::Tensor& pixels, int factor = 8);

// Mean over matches and channels of |z_i(x_i) - z_j(x_j)| for one view pair.
torch::Tensor correspondence_l1(const torch::Tensor& latent_i, const torch::Tensor& latent_j, const torch::Tensor& xi,
                                const torch::Tensor& xj, int factor = 8);

// Share of a latent's spectral energy (per channel, mean removed) above half the Nyquist frequency:
// frequencies with max(|fx|, |fy|) > 0.25 cycles per latent pixel. latent: [C, h, w].
double high_frequency_energy_share(const torch::Tensor& latent);

}  // namespace lrf
