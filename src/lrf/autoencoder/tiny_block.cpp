#include "lrf/autoencoder/tiny_block.h"

#include <torch/torch.h>

#include "lrf/core/error.h"

namespace lrf {

namespace nn = torch::nn;

MixedConv2d tiny_conv3x3(int in, int out, int stride, bool bias) {
  return MixedConv2d(nn::Conv2dOptions(in, out, 3).stride(stride).padding(1).bias(bias));
}

TinyBlockImpl::TinyBlockImpl(int channels, bool with_pool) {
  // In-place ReLUs: the convolutions' backward does not need their outputs, so this is autograd-safe
  // and saves an allocation + pass over memory per activation.
  auto relu = [] { return nn::ReLU(nn::ReLUOptions().inplace(true)); };
  conv = register_module("conv", nn::Sequential(tiny_conv3x3(channels, channels), relu(), tiny_conv3x3(channels, channels),
                                                relu(), tiny_conv3x3(channels, channels)));
  if (with_pool) {
    // Widening x4 is in TAEF2's weight shapes (256 = 4 x 64). The group count is not: 4 groups is the
    // public taesd.py FLUX.2 variant's choice, and the round-trip PSNR on fern confirms it (other
    // counts reconstruct measurably worse; see the issue note).
    const int wide = channels * 4;
    auto conv1 = [](int in, int out) { return MixedConv2d(nn::Conv2dOptions(in, out, 1).bias(false)); };
    pool = register_module("pool", nn::Sequential(conv1(channels, wide), MixedGroupNorm(nn::GroupNormOptions(4, wide)),
                                                  nn::ReLU(), conv1(wide, channels)));
  }
}

at::Tensor TinyBlockImpl::forward(at::Tensor x) {
  if (pool) x = x + pool->forward(x);
  // The ReLU modules between the convolutions are applied by the convolutions themselves (forward_with),
  // which in bf16 training store relu(conv + residual) in one pass; the modules stay for the layout.
  at::Tensor h = conv->at<MixedConv2dImpl>(0).forward_with(x, {}, true);
  h = conv->at<MixedConv2dImpl>(2).forward_with(h, {}, true);
  return conv->at<MixedConv2dImpl>(4).forward_with(h, x, true);
}

at::Tensor TinyBlockImpl::forward_cut(const at::Tensor& x,
                                      const std::function<at::Tensor(const at::Tensor&, int64_t)>& cut) {
  if (pool) fail("tiny autoencoder: a block with the group-norm branch needs the whole image, not a window");
  at::Tensor h = cut(conv->at<MixedConv2dImpl>(0).forward_with(x, {}, true), 1);
  h = cut(conv->at<MixedConv2dImpl>(2).forward_with(h, {}, true), 1);
  return cut(conv->at<MixedConv2dImpl>(4).forward_with(h, cut(x, 2), true), 1);
}

}  // namespace lrf
