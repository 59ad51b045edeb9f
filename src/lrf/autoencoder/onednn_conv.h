#pragma once
// A 2D convolution for inference, run through oneDNN directly (the library libtorch itself calls for its
// CPU convolutions) so that a residual add and a ReLU happen as the outputs are stored. libtorch 1.13 has
// no such fusion: there each ReLU and each residual add is one more pass over an activation, which in
// the tiny autoencoders' decoder costs about a third of the decode (bench_autoencoder fused).
#include <cstdint>
#include <memory>

#include <ATen/core/Tensor.h>

namespace lrf {

class FusedConv2d {
 public:
  // weight [O, I, kh, kw] (float32, any memory layout; copied), bias [O] or undefined; zero padding
  // `padding` on every side.
  FusedConv2d(const at::Tensor& weight, const at::Tensor& bias, int stride, int padding);
  ~FusedConv2d();
  FusedConv2d(const FusedConv2d&) = delete;
  FusedConv2d& operator=(const FusedConv2d&) = delete;

  // input [N, I, H, W], bf16 or float32 (bf16: products in bf16, sums in float32, as at::conv2d's bf16
  // path). Returns [N, O, H', W'] channels-last in the input's dtype: conv + bias, then + `residual`
  // when it is defined, then the ReLU when `relu`. A defined `residual` must be channels-last with the
  // output's shape and dtype; the result is written into it (its values are consumed) and it is
  // returned. Thread-safe; each new input shape builds (and keeps) its own oneDNN primitive.
  at::Tensor forward(const at::Tensor& input, bool relu, const at::Tensor& residual = {}) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Whether the autoencoders' inference may use FusedConv2d: yes unless LRF_FUSED_CONV=0 (kept to compare
// against libtorch's path, and as a way out should a oneDNN build misbehave).
bool fused_conv_enabled();

}  // namespace lrf
