#include "lrf/autoencoder/conv/conv_destination.h"

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

}  // namespace lrf
