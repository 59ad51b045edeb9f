#pragma once
// The Gaussian field: one row per Gaussian in each parameter tensor (all float32, CPU, leaves that
// require grad). Features are spherical-harmonic coefficients for C channels (C = 3 for RGB, 4 or 32
// for latents) in one contiguous tensor `sh` [N, K, C], K = (max_sh_degree + 1)^2; band 0 ("DC") and
// the higher bands ("rest") are views of it. One leaf instead of two separate ones saves a full copy of
// the features per iteration (a cat forward and a split backward: 100 MB at C = 32, degree 3, 50k
// Gaussians); the optimizer still gives the two bands their own learning rates.
#include <cstdint>
#include <functional>
#include <vector>

#include <torch/types.h>

#include "lrf/scene/camera.h"

namespace lrf::splat {

// Zeroth-order SH basis constant: colour = C0 * dc + 0.5 (the Inria convention).
constexpr double kShC0 = 0.28209479177387814;

inline int sh_coefficients(int degree) { return (degree + 1) * (degree + 1); }

struct Gaussians {
  torch::Tensor means;           // [N, 3]
  torch::Tensor log_scales;      // [N, 3]
  torch::Tensor quats;           // [N, 4] (w, x, y, z), not necessarily normalised
  torch::Tensor opacity_logits;  // [N, 1]
  torch::Tensor sh;              // [N, K, C]
  int max_sh_degree = 0;

  int64_t size() const { return means.defined() ? means.size(0) : 0; }
  int channels() const { return static_cast<int>(sh.size(2)); }
  torch::Tensor sh_dc() const { return sh.narrow(1, 0, 1); }  // [N, 1, C]
  torch::Tensor sh_rest() const { return sh.narrow(1, 1, sh.size(1) - 1); }  // [N, K-1, C]

  // The parameter tensors in a fixed order (means, log_scales, quats, opacity_logits, sh); the
  // optimizer and checkpoints index them the same way.
  std::vector<torch::Tensor*> parameters();
  std::vector<const torch::Tensor*> parameters() const;
  static const std::vector<std::string>& parameter_names();
  // Makes every parameter a contiguous float32 leaf that requires grad.
  void make_leaves();
  // Throws lrf::Error(what, ...) when shapes disagree with each other.
  void check(const std::string& what) const;
  Gaussians clone() const;  // detached deep copy
  // Rows in the given order (int64 [N], a permutation), as leaves that require grad.
  void permute_rows(const torch::Tensor& order);
};

// Features in target space ([0, 1] for RGB and normalised latents) -> DC coefficients, and back.
torch::Tensor features_to_sh_dc(const torch::Tensor& features);
torch::Tensor sh_dc_to_features(const torch::Tensor& dc);

// Mean squared distance of every point to its 3 nearest neighbours (as Inria's simple-knn does),
// found with a uniform grid: O(N) for well-spread points. xyz [N, 3] -> [N]. N < 4 uses what exists.
torch::Tensor mean_sq_dist_3nn(const torch::Tensor& xyz);

// Builds a field from points xyz [N, 3] and their features [N, C] in target space: scales from the
// 3-NN distance, identity rotations, opacity 0.1, higher SH bands zero.
Gaussians gaussians_from_points(const torch::Tensor& xyz, const torch::Tensor& features,
                                int max_sh_degree);

// `count` points uniform in the axis-aligned cube centre +- half_size (reproducible from `seed`).
torch::Tensor random_points(int64_t count, const Eigen::Vector3d& centre, double half_size, uint64_t seed);

}  // namespace lrf::splat
