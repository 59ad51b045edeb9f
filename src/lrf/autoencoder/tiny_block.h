#pragma once
// The tiny autoencoder's layers that its decoder paths share: the zero-padded 3x3 convolution and the
// residual block (tiny_ae.h describes the architecture).
#include <functional>

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
  // forward() of a window of the image that sheds a ring on some sides: after each convolution, `cut`
  // removes the outermost ring where its zero padding stood for pixels the window lacks, and the residual
  // is cut to match (so the output has 3 pixels fewer on those sides). Blocks with the pool branch need
  // the whole image and are refused.
  at::Tensor forward_cut(const at::Tensor& x, const std::function<at::Tensor(const at::Tensor&, int64_t)>& cut);
  torch::nn::Sequential conv{nullptr};
  torch::nn::Sequential pool{nullptr};
};
TORCH_MODULE(TinyBlock);

}  // namespace lrf
