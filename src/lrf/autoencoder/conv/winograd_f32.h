#pragma once
// 3x3 convolutions (stride 1, zero padding 1) of float32 channels-last images by Winograd's algorithm, for
// CPUs whose fast path is float32 (no native bf16): AVX2 with FMA or AVX-512F, chosen at run time
// (simd_level(), capped by $LRF_CPU_ISA). F(4x4, 3x3) by default: each 4x4 block of outputs is 36
// products of transformed 6x6 input patches with transformed kernels, where the direct convolution needs
// 144, so a quarter of the multiply-adds; F(2x2, 3x3) (16 per 4 outputs, 4/9) is kept for comparison.
// Everything is float32: the transforms, the products and their sums. The error against float64 is a few
// times the direct convolution's (the transforms' constants up to 8 amplify rounding; test_winograd_f32
// measures it), far below anything an image or a gradient step notices.
// Used by inference (FusedConv2d, UpsampledConv2d) and by training (MixedConv2d), where the input
// gradient is the same convolution of the output's gradient with the kernels transposed and flipped, and
// the weight gradient is taken in the transformed domain: dU = Σ_tiles (A dY Aᵀ) ⊙ (Bᵀ d B), dW = Gᵀ dU G.
#include <cstdint>
#include <vector>

#include <ATen/core/Tensor.h>

namespace lrf {

class WinogradF32Conv3x3 {
 public:
  // Whether this CPU runs the kernels now (winograd_f32_enabled()) and takes these channel counts:
  // multiples of the vector's lanes (8 with AVX2, 16 with AVX-512F) both ways.
  static bool runs(int64_t outputs, int64_t inputs);
  // The output tile side: 4 unless $LRF_WINOGRAD_F32_TILE is 2 or 6.
  static int chosen_tile();

  // weight [O, I, 3, 3] and bias [O] or undefined (any dtype and layout; copied and transformed in
  // float64, rounded once). `upsampled_input`: convolve the input upsampled 2x (nearest), read in place.
  WinogradF32Conv3x3(const at::Tensor& weight, const at::Tensor& bias, bool upsampled_input = false,
                     int tile = chosen_tile());

  // input float32 [N, I, H, W] (any layout) -> [N, O, H, W] ([N, O, 2H, 2W] upsampled) float32
  // channels-last: conv + bias, + `residual` when defined (channels-last float32 of the output's shape, not
  // overlapping the input; it receives the result and is returned), then the ReLU when `relu`. Needs runs().
  at::Tensor forward(const at::Tensor& input, bool relu, const at::Tensor& residual = {}) const;

 private:
  int64_t outputs_ = 0, inputs_ = 0;
  bool upsampled_ = false;
  int tile_ = 4;
  std::vector<float> kernels_;  // [positions][I][O]
  std::vector<float> bias_;     // [O]
};

struct ConvParameterGradients;

// The weight and bias gradients of Σ grad_output · conv2d(input, weight, bias, stride 1, padding 1), for
// float32 input [N, I, H, W] and grad_output [N, O, H, W] (any layout), by the transformed domain's
// products. Deterministic for a given thread count (per-thread sums added in a fixed order). Needs
// WinogradF32Conv3x3::runs(O, I).
ConvParameterGradients winograd_f32_weight_gradient(const at::Tensor& input, const at::Tensor& grad_output,
                                                    int tile = WinogradF32Conv3x3::chosen_tile());

// Whether winograd_f32_conv3x3_trained runs this convolution: a float32 input, a float32 weight
// [O, I, 3, 3] (stride 1, padding 1, no dilation or groups, which the caller checks) whose channel counts
// the kernels take both ways, on a CPU that runs them.
bool winograd_f32_trains(const at::Tensor& input, const at::Tensor& weight);

// relu?(conv2d(input, weight, bias, stride 1, padding 1) + residual) with autograd, all three passes by
// Winograd: the forward, the input gradient (the output gradient convolved with the transposed, flipped
// kernels) and the weight and bias gradients. The residual and the ReLU are applied as the convolution
// stores its outputs, and the ReLU's mask as its backward reads the gradient (libtorch would spend one
// pass over the activation on each). `residual` undefined or of the output's shape (not modified).
// Returns float32 channels-last.
at::Tensor winograd_f32_conv3x3_trained(const at::Tensor& input, const at::Tensor& weight, const at::Tensor& bias,
                                        const at::Tensor& residual = {}, bool relu = false);

}  // namespace lrf
