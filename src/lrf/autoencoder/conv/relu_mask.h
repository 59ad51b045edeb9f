#pragma once
// The gradient through a ReLU for the Winograd training functions: g where the ReLU's output y is
// positive, else 0. Read on the bit patterns as signed integers of the element's width (a positive float or
// bf16 is a positive integer), branch-free (the signs of a ReLU's input are close to random, so a branch
// mispredicts half the time) and on restrict pointers, so that the loop compiles to vector compares and ands.
#include <cstdint>

#include <ATen/ATen.h>
#include <ATen/Parallel.h>

namespace lrf {

// Bits: int16_t for bf16 tensors, int32_t for float32 ones. g and y channels-last, of one shape and dtype.
template <typename Bits>
at::Tensor relu_masked(const at::Tensor& g, const at::Tensor& y) {
  at::Tensor out = at::empty_like(g, at::MemoryFormat::ChannelsLast);
  const auto* gp = reinterpret_cast<const Bits*>(g.data_ptr());
  const auto* yp = reinterpret_cast<const Bits*>(y.data_ptr());
  auto* op = reinterpret_cast<Bits*>(out.data_ptr());
  at::parallel_for(0, g.numel(), 1 << 16, [=](int64_t begin, int64_t end) {
    const Bits* __restrict from = gp + begin;
    const Bits* __restrict sign = yp + begin;
    Bits* __restrict to = op + begin;
    for (int64_t k = 0; k < end - begin; ++k) to[k] = static_cast<Bits>(from[k] & -static_cast<Bits>(sign[k] > 0));
  });
  return out;
}

}  // namespace lrf
