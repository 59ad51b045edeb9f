#pragma once
// The tiny autoencoder's layers that its decoder paths share: the zero-padded 3x3 convolution and the
// residual block (tiny_ae.h describes the architecture).
#include <torch/nn/module.h>
#include <torch/nn/modules/container/sequential.h>

#include "lrf/autoencoder/mixed_layers.h"

namespace lrf {

// A 3x3 convolution, zero padding 1.
MixedConv2d tiny_conv3x3(int in, int out, int stride = 1, bool bias = true);

// Residual block: relu(conv(x) + x), `conv` being three 3x3 convolutions with ReLUs between them;
// optionally preceded by TAEF2's global-statistics branch x += pool(x).
struct TinyBlockImpl : torch::nn::Module {
  TinyBlockImpl(int channels, bool with_pool);
  at::Tensor forward(at::Tensor x);
  torch::nn::Sequential conv{nullptr};
  torch::nn::Sequential pool{nullptr};
};
TORCH_MODULE(TinyBlock);

}  // namespace lrf
