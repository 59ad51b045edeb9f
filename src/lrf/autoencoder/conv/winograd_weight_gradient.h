#pragma once
// The weight and bias gradients of a 3x3 convolution (stride 1, zero padding 1) of bf16 channels-last
// images, by the transpose of Winograd's F(2x2, 3x3) (winograd_conv.h): with V = Bᵀ d B the transformed
// 4x4 input patch of a 2x2 output tile and dM = A dY Aᵀ the output gradient carried back through the
// output transform, the transformed kernels' gradient is dU[p][o][i] = Σ_tiles dM[p][o] V[p][i] at each
// of the 16 positions p, and the kernels' dW = Gᵀ dU G. That is 16 products per tile where the direct
// gradient needs 36: 4/9 of the multiply-adds, which in a training step of the autoencoders were the
// largest convolution cost left (oneDNN's bf16 weight gradient runs at ~70 % of its forward's rate here).
// The sums over tiles are AVX512_BF16 dot products of bf16 pairs of neighbouring tiles accumulated in
// float32; the transforms are done in float32 and rounded to bf16 once, as in the forward.
#include <cstdint>

#include <ATen/core/Tensor.h>

namespace lrf {

struct ConvParameterGradients {
  at::Tensor weight;  // float32 [O, I, 3, 3]
  at::Tensor bias;    // float32 [O]
};

// Channel counts it handles: inputs a multiple of 64 (summed 64 at a time), outputs a multiple of 32
// (transformed 32 at a time).
bool winograd_weight_gradient_takes(int64_t outputs, int64_t inputs);

// input bf16 [N, I, H, W] and grad_output bf16 [N, O, H, W] (any layout: read channels-last) -> the
// gradients of Σ grad_output · conv2d(input, weight, bias, stride 1, padding 1) with respect to weight and
// bias, summed over the batch. Needs WinogradConv3x3::available() and winograd_weight_gradient_takes.
// Deterministic for a given thread count: per-thread partial sums are added in a fixed order.
ConvParameterGradients winograd_weight_gradient(const at::Tensor& input, const at::Tensor& grad_output);

}  // namespace lrf
