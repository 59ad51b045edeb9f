#pragma once
// A transposed convolution with kernel 2 and stride 2 (no padding), computed as what it equals: a 1x1
// convolution to 4·out channels followed by a pixel shuffle. oneDNN runs the 1x1 convolution as one
// matrix product; libtorch's transposed convolution is several times slower on CPU.
#include <torch/nn/module.h>

namespace lrf {

// out[o, 2y+i, 2x+j] = bias[o] + sum_c x[c, y, x] · weight[c, o, i, j], with PyTorch's ConvTranspose2d
// weight layout [in, out, 2, 2]; computed in the dtype of `x` (weight and bias cast), differentiable.
at::Tensor transposed_conv2x2(const at::Tensor& x, const at::Tensor& weight, const at::Tensor& bias);

// The layer: parameters "weight" [in, out, 2, 2] and "bias" [out], initialised as ConvTranspose2d's.
class TransposedUp2Impl : public torch::nn::Module {
 public:
  TransposedUp2Impl(int in, int out);
  at::Tensor forward(const at::Tensor& x) { return transposed_conv2x2(x, weight, bias); }
  at::Tensor weight, bias;
};
TORCH_MODULE(TransposedUp2);

}  // namespace lrf
