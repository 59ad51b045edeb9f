#pragma once
// The feature-gs baseline (Feature 3DGS's speed-up module, Zhou et al. 2024): the Gaussians carry a
// D-dimensional feature instead of the C latent channels, the rasterizer renders that low-dimensional map,
// and a 1x1 convolution trained with the field lifts it to the C channels of the autoencoder's latent.
// This file is that convolution: y[c, p] = sum_d W[c, d] x[d, p] + b[c] at every pixel p.
//
// A field's lift is stored beside its point_cloud.ply as OUT/lift.safetensors: tensors "weight" [C, D] and
// "bias" [C] (float32) with metadata lrf_kind = "feature-lift".
#include <cstdint>
#include <string>
#include <vector>

#include <ATen/Tensor.h>

namespace lrf {

// Feature 3DGS's speed-up module renders half the target's channels (its README: `NUMBER = 2`, the setup
// of its experiments; SAM's 256 -> 128, LSeg's 512 -> 256); for TAEF2's 32 latent channels, 16.
int default_feature_dim(int latent_channels);
// The largest --feature-dim accepted: beyond it a feature field costs more than any latent field lrf fits.
constexpr int kMaxFeatureDim = 512;

struct FeatureLift {
  at::Tensor weight;  // [C, D]
  at::Tensor bias;    // [C]

  bool defined() const { return weight.defined(); }
  int64_t feature_dim() const { return weight.size(1); }
  int64_t channels() const { return weight.size(0); }
  std::vector<at::Tensor> parameters() const { return {weight, bias}; }

  // PyTorch's default Conv2d initialisation, as Feature 3DGS's decoder starts: weight and bias uniform in
  // +-1/sqrt(D) (kaiming_uniform with a = sqrt(5)), drawn from `seed`. Both require grad.
  static FeatureLift initial(int feature_dim, int channels, uint64_t seed);

  // features [D, H, W] -> [C, H, W]; differentiable through autograd with respect to the features, the
  // weight and the bias.
  at::Tensor apply(const at::Tensor& features) const;

  // Writes OUT/lift.safetensors-style files atomically.
  void save(const std::string& path) const;
  // Reads a lift; throws lrf::Error naming `path` when it is not one, has other shapes than
  // [channels, feature_dim] / [channels], or holds NaN or infinite values.
  static FeatureLift load(const std::string& path, int feature_dim, int channels);
};

}  // namespace lrf
