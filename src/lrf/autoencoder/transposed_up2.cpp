#include "lrf/autoencoder/transposed_up2.h"

#include <cmath>

#include <torch/torch.h>

namespace lrf {

at::Tensor transposed_conv2x2(const at::Tensor& x, const at::Tensor& weight, const at::Tensor& bias) {
  const int64_t in = weight.size(0), out = weight.size(1);
  // Output channel o·4 + i·2 + j of the 1x1 convolution is pixel (i, j) of channel o after the shuffle.
  const at::Tensor w = weight.permute({1, 2, 3, 0}).reshape({out * 4, in, 1, 1}).to(x.scalar_type());
  const at::Tensor b = bias.repeat_interleave(4).to(x.scalar_type());
  return at::pixel_shuffle(at::conv2d(x, w, b), 2);
}

TransposedUp2Impl::TransposedUp2Impl(int in, int out) {
  weight = register_parameter("weight", torch::empty({in, out, 2, 2}));
  bias = register_parameter("bias", torch::empty({out}));
  // ConvTranspose2d's default: kaiming_uniform(a = sqrt(5)), whose fan-in for this layout is out·2·2.
  torch::NoGradGuard no_grad;
  torch::nn::init::kaiming_uniform_(weight, std::sqrt(5.0));
  const double bound = 1.0 / std::sqrt(static_cast<double>(out * 4));
  bias.uniform_(-bound, bound);
}

}  // namespace lrf
