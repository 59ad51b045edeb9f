#pragma once
// The two layers of the autoencoders that hold weights, made to compute in the dtype of their input
// while their parameters stay float32. The parameters are what optimisers, checkpoints and weight files
// see (fp32 "master" weights); a bf16 input runs a bf16 layer on weights cast for that call. The cast
// is part of the autograd graph, so weight gradients arrive at the parameters as float32 and Adam's
// state stays float32. Parameter names, shapes and initialisation are those of torch::nn's layers.
#include <torch/nn/modules/conv.h>
#include <torch/nn/modules/normalization.h>

namespace lrf {

// A 3x3 / 1x1 convolution (zero padding, as every autoencoder layer uses).
class MixedConv2dImpl : public torch::nn::Conv2dImpl {
 public:
  explicit MixedConv2dImpl(const torch::nn::Conv2dOptions& options);
  at::Tensor forward(const at::Tensor& input);

 private:
  // A bf16 convolution whose weight gradient will be taken, on an output larger than one tile.
  bool needs_tiles(const at::Tensor& input) const;
  // The same convolution computed tile by tile (see mixed_layers.cpp for why).
  at::Tensor tiled_forward(const at::Tensor& input);
};
TORCH_MODULE(MixedConv2d);

// Group normalisation, computed in float32 whatever the input dtype (the output has the input's
// dtype): its statistics run over whole groups, where bf16's 8-bit mantissa would lose the mean.
class MixedGroupNormImpl : public torch::nn::GroupNormImpl {
 public:
  explicit MixedGroupNormImpl(const torch::nn::GroupNormOptions& options);
  at::Tensor forward(const at::Tensor& input);
};
TORCH_MODULE(MixedGroupNorm);

}  // namespace lrf
