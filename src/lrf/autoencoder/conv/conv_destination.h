#pragma once
// Where an inference convolution writes (a new channels-last tensor, or the residual it adds to), and the
// bias it adds.
#include <cstdint>
#include <string>
#include <vector>

#include <ATen/core/Tensor.h>

namespace lrf {

// A new channels-last tensor of `shape` in the input's dtype, or, when `residual` is defined, the
// residual itself after checking that it is channels-last, of `shape` and dtype, and does not overlap
// `input` (which is still being read while outputs are stored). `who` names the caller in errors.
at::Tensor conv_destination(const std::string& who, const at::Tensor& input, const at::Tensor& residual,
                            const std::vector<int64_t>& shape);

// `bias` ([outputs], any dtype) as float32, or zeros when it is undefined; `who` names the caller in errors.
std::vector<float> conv_bias(const std::string& who, const at::Tensor& bias, int64_t outputs);

}  // namespace lrf
