#pragma once
// A 2D convolution for inference, run through oneDNN directly (the library libtorch itself calls for its
// CPU convolutions) so that a residual add and a ReLU happen as the outputs are stored. libtorch 1.13 has
// no such fusion: there each ReLU and each residual add is one more pass over an activation, which in
// the tiny autoencoders' decoder costs about a third of the decode (bench_autoencoder fused).
#include <cstdint>
#include <memory>

#include <ATen/core/Tensor.h>

namespace lrf {

class WinogradConv3x3;
class WinogradF32Conv3x3;

class FusedConv2d {
 public:
  // weight [O, I, kh, kw] (float32, any memory layout; copied), bias [O] or undefined; zero padding
  // `padding` on every side.
  FusedConv2d(const at::Tensor& weight, const at::Tensor& bias, int stride, int padding);
  ~FusedConv2d();
  FusedConv2d(const FusedConv2d&) = delete;
  FusedConv2d& operator=(const FusedConv2d&) = delete;

  // input [N, I, H, W], bf16 or float32 (bf16: products in bf16, sums in float32, as at::conv2d's bf16
  // path; a 3x3 convolution with stride 1 and padding 1 runs as WinogradConv3x3 or, to 1 to 3 outputs, as
  // NarrowConv3x3 where those take it, and in float32 as WinogradF32Conv3x3 where the CPU has AVX2).
  // Returns [N, O, H', W'] channels-last in the input's dtype: conv + bias, then + `residual`
  // when it is defined, then the ReLU when `relu`. A defined `residual` must be channels-last with the
  // output's shape and dtype and must not overlap the input; the result is written into it (its
  // values are consumed) and it is returned. Thread-safe; each new input shape builds (and keeps) its own oneDNN primitive.
  at::Tensor forward(const at::Tensor& input, bool relu, const at::Tensor& residual = {}) const;

  // Which kernel a bf16 input runs on now: Winograd's (winograd_conv.h), the narrow one (narrow_conv.h)
  // or oneDNN's direct one. forward() dispatches on it.
  enum class Kernel { winograd, narrow, onednn };
  Kernel bf16_kernel() const;

 private:
  // A bf16 input where oneDNN has no bf16 convolution: converted to float32, convolved, rounded back.
  at::Tensor forward_bf16_in_float32(const at::Tensor& input, bool relu, const at::Tensor& residual) const;

  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// A 2x nearest-neighbour upsampling followed by a 3x3 convolution (zero padding 1, stride 1), computed
// without the upsampled image: each output pixel's nine taps fall on only 2x2 distinct input pixels, so
// the four output phases (row and column parity) are four 2x2 convolutions of the input with weights
// summed from the 3x3 kernel's rows and columns: 4/9 of the multiply-adds, and no pass writing the
// upsampled image. They run as one 2x2 convolution with 4·O outputs (padding 1), whose phases are then
// interleaved into the output. The value is the composition's up to the order of float32 sums (and, in
// bf16, the rounding of the summed weights instead of each weight).
class UpsampledConv2d {
 public:
  // weight [O, I, 3, 3] (float32, any layout; copied), bias [O] or undefined.
  UpsampledConv2d(const at::Tensor& weight, const at::Tensor& bias);
  ~UpsampledConv2d();
  UpsampledConv2d(const UpsampledConv2d&) = delete;
  UpsampledConv2d& operator=(const UpsampledConv2d&) = delete;

  // input [N, I, H, W] (bf16 or float32) -> conv(upsample2x(input)) [N, O, 2H, 2W], channels-last,
  // ReLU'd when `relu`.
  at::Tensor forward(const at::Tensor& input, bool relu) const;

 private:
  int64_t outputs_ = 0;
  std::unique_ptr<FusedConv2d> phases_;  // the 2x2 convolution with 4·O outputs
  // bf16 where the CPU has AVX512_BF16 and the channel counts fit: Winograd on the upsampled image,
  // 9/16 of the phases' multiply-adds and no interleaving pass.
  std::unique_ptr<WinogradConv3x3> winograd_;
  // float32 where the CPU has AVX2 or AVX-512F: Winograd F(4x4) on the upsampled image read in place,
  // 36 products per 16 outputs against the phases' 64.
  std::unique_ptr<WinogradF32Conv3x3> winograd_f32_;
  int64_t winograd_inputs_ = 0;
};

}  // namespace lrf
