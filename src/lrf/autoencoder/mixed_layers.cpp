#include "lrf/autoencoder/mixed_layers.h"

#include <ATen/ATen.h>

#include "lrf/core/error.h"

namespace lrf {

MixedConv2dImpl::MixedConv2dImpl(const torch::nn::Conv2dOptions& options) : torch::nn::Conv2dImpl(options) {
  if (!c10::holds_alternative<torch::ExpandingArray<2>>(options.padding()) ||
      !c10::holds_alternative<torch::enumtype::kZeros>(options.padding_mode())) {
    fail("MixedConv2d: only explicit zero padding is supported");
  }
}

at::Tensor MixedConv2dImpl::forward(const at::Tensor& input) {
  const auto dtype = input.scalar_type();
  // Same dtype: no cast, so fp32 runs exactly the plain layer's arithmetic.
  at::Tensor w = weight.scalar_type() == dtype ? weight : weight.to(dtype);
  at::Tensor b = !bias.defined() || bias.scalar_type() == dtype ? bias : bias.to(dtype);
  return at::conv2d(input, w, b, options.stride(), c10::get<torch::ExpandingArray<2>>(options.padding()),
                    options.dilation(), options.groups());
}

MixedGroupNormImpl::MixedGroupNormImpl(const torch::nn::GroupNormOptions& options)
    : torch::nn::GroupNormImpl(options) {}

at::Tensor MixedGroupNormImpl::forward(const at::Tensor& input) {
  if (input.scalar_type() == at::kFloat) return torch::nn::GroupNormImpl::forward(input);
  return torch::nn::GroupNormImpl::forward(input.to(at::kFloat)).to(input.scalar_type());
}

}  // namespace lrf
