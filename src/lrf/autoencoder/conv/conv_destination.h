#pragma once
// Where an inference convolution writes: a new channels-last tensor, or the residual it adds to.
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

}  // namespace lrf
