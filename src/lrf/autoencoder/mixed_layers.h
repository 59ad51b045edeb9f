#pragma once
// The two layers of the autoencoders that hold weights, made to compute in the dtype of their input
// while their parameters stay float32. The parameters are what optimisers, checkpoints and weight files
// see (fp32 "master" weights); a bf16 input runs a bf16 layer on weights cast for that call. The cast
// is part of the autograd graph, so weight gradients arrive at the parameters as float32 and Adam's
// state stays float32. Parameter names, shapes and initialisation are those of torch::nn's layers.
#include <torch/nn/modules/conv.h>
#include <torch/nn/modules/normalization.h>

namespace lrf {

// A 3x3 / 1x1 convolution (zero padding, as every autoencoder layer uses). In bf16, the 3x3 ones of
// stride 1 with multiples of 64 channels run as Winograd's where the CPU has AVX512_BF16; in float32,
// those whose channels are multiples of the vector lanes run as Winograd's where the CPU has AVX2 or
// AVX-512F (winograd_f32.h), all three passes.
class MixedConv2dImpl : public torch::nn::Conv2dImpl {
 public:
  explicit MixedConv2dImpl(const torch::nn::Conv2dOptions& options);
  at::Tensor forward(const at::Tensor& input);
  // relu?(forward(input) + residual), `residual` undefined for none. Where Winograd runs, the residual and
  // the ReLU are applied as the convolution stores its outputs (winograd_training.h).
  at::Tensor forward_with(const at::Tensor& input, const at::Tensor& residual, bool relu);

 private:
  // A bf16 convolution whose weight gradient will be taken, on an output larger than one tile.
  bool needs_tiles(const at::Tensor& input) const;
  // A bf16 3x3 convolution that Winograd runs, forward and input gradient
  // (winograd_training.h): one that needs no tiles.
  bool runs_winograd(const at::Tensor& input) const;
  // A 3x3 convolution of stride 1 and padding 1 (no dilation or groups): what Winograd's kernels compute.
  bool is_same_3x3() const;
};
TORCH_MODULE(MixedConv2d);

// The zero-padded convolution of `input` (weight and bias cast to the input's dtype), whose gradients are
// computed on output tiles of at most tile x tile pixels, each from its own window of the input: the
// value and gradients are those of at::conv2d; the tiles only bound the size of each backward call
// (MixedConv2d uses it for bf16 training outside Winograd, where oneDNN's AMX weight gradient of large
// images is wrong). The weight gradient is summed over the tiles in the weight's dtype.
at::Tensor conv2d_in_tiles(const at::Tensor& input, const at::Tensor& weight, const at::Tensor& bias,
                           at::IntArrayRef stride, at::IntArrayRef padding, at::IntArrayRef dilation, int64_t groups,
                           int64_t tile);

// Group normalisation, computed in float32 whatever the input dtype (the output has the input's
// dtype): its statistics run over whole groups, where bf16's 8-bit mantissa would lose the mean.
class MixedGroupNormImpl : public torch::nn::GroupNormImpl {
 public:
  explicit MixedGroupNormImpl(const torch::nn::GroupNormOptions& options);
  at::Tensor forward(const at::Tensor& input);
};
TORCH_MODULE(MixedGroupNorm);

}  // namespace lrf
