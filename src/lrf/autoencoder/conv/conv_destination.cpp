#include "lrf/autoencoder/conv/conv_destination.h"

#include <algorithm>

#include <ATen/ATen.h>

#include "lrf/core/error.h"

namespace lrf {

at::Tensor conv_destination(const std::string& who, const at::Tensor& input, const at::Tensor& residual,
                            const std::vector<int64_t>& shape) {
  if (!residual.defined()) return at::empty(shape, input.options().memory_format(at::MemoryFormat::ChannelsLast));
  const auto dtype = input.scalar_type();
  if (residual.sizes() != at::IntArrayRef(shape) || residual.scalar_type() != dtype ||
      !residual.is_contiguous(at::MemoryFormat::ChannelsLast)) {
    fail(who + ": the residual must be a channels-last " + std::string(c10::toString(dtype)) + " tensor of " +
         c10::str(at::IntArrayRef(shape)) + ", got " + c10::str(residual.sizes()));
  }
  const auto* in_begin = static_cast<const char*>(input.data_ptr());
  const auto* res_begin = static_cast<const char*>(residual.data_ptr());
  if (res_begin < in_begin + input.nbytes() && in_begin < res_begin + residual.nbytes()) {
    fail(who + ": the residual shares memory with the input");
  }
  return residual;
}

std::vector<float> conv_bias(const std::string& who, const at::Tensor& bias, int64_t outputs) {
  std::vector<float> out(static_cast<size_t>(outputs), 0.f);
  if (!bias.defined()) return out;
  if (bias.dim() != 1 || bias.size(0) != outputs) fail(who + ": bias must be [O], got " + c10::str(bias.sizes()));
  const at::Tensor b = bias.detach().to(at::kFloat).contiguous();
  std::copy(b.data_ptr<float>(), b.data_ptr<float>() + outputs, out.begin());
  return out;
}

}  // namespace lrf
