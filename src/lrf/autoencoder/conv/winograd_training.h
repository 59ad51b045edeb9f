#pragma once
// The autoencoders' 3x3 convolutions while training in bf16, by Winograd (winograd_conv.h) in all three
// passes: the forward and the gradient of the input, which is itself a 3x3 convolution of the output's
// gradient (kernels transposed and flipped), with the tiles WinogradConv3x3::chosen_tiles() names (3x3
// unless $LRF_WINOGRAD_TILE=2); and the weight and bias gradients, by F(2x2, 3x3)'s transposed
// transforms (winograd_weight_gradient.h). A residual and a ReLU after the convolution are
// applied as it stores its outputs, and their backward (the ReLU's mask) as the gradient is read:
// libtorch 1.13's bf16 adds and ReLU gradients are slow elementwise passes, which in a residual block
// cost as much as the convolutions.
#include <ATen/core/Tensor.h>

namespace lrf {

// Whether winograd_conv3x3_trained() runs this convolution: a bf16 input, weights [O, I, 3, 3] (stride
// 1, padding 1, no dilation or groups, which the caller checks) whose channel counts WinogradConv3x3
// takes both ways (forward O x I, input gradient I x O) and winograd_weight_gradient_takes, on a CPU that
// runs it.
bool winograd_trains(const at::Tensor& input, const at::Tensor& weight);

// relu?(conv2d(input, weight, bias, stride 1, padding 1) + residual) with autograd: input bf16 [N, I, H,
// W] (any layout), weight float32 [O, I, 3, 3] and bias float32 [O] or undefined (the master weights:
// their gradients arrive as float32, summed in float32 from bf16 products), residual undefined
// or of the output's shape (read as bf16, not modified). Returns bf16 channels-last. Needs
// winograd_trains(input, weight).
at::Tensor winograd_conv3x3_trained(const at::Tensor& input, const at::Tensor& weight, const at::Tensor& bias,
                                    const at::Tensor& residual = {}, bool relu = false);

}  // namespace lrf
