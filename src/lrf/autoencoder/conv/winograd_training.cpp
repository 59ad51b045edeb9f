#include "lrf/autoencoder/conv/winograd_training.h"

#include <cstdint>

#include <ATen/ATen.h>
#include <ATen/Parallel.h>
#include <torch/autograd.h>

#include "lrf/autoencoder/conv/relu_mask.h"
#include "lrf/autoencoder/conv/winograd_conv.h"
#include "lrf/autoencoder/conv/winograd_weight_gradient.h"
#include "lrf/core/error.h"

namespace lrf {
namespace {

using torch::autograd::AutogradContext;
using torch::autograd::variable_list;

class WinogradConvFunction : public torch::autograd::Function<WinogradConvFunction> {
 public:
  // `residual`: a tensor of no elements when there is none (autograd::Function takes no undefined inputs).
  static at::Tensor forward(AutogradContext* ctx, const at::Tensor& input, const at::Tensor& weight,
                            const at::Tensor& bias, const at::Tensor& residual, bool relu) {
    const at::Tensor x = input.contiguous(at::MemoryFormat::ChannelsLast);
    at::Tensor into;
    if (residual.numel() > 0) {
      // The convolution adds itself into this copy, which becomes the output.
      into = residual.to(at::kBFloat16).clone(at::MemoryFormat::ChannelsLast);
    }
    // The weights change with every optimiser step, so they are transformed on each call (~0.15 ms for
    // 64x64, against the convolution's milliseconds).
    const at::Tensor y = WinogradConv3x3(weight, bias, false, WinogradConv3x3::chosen_tiles()).forward(x, relu, into);
    ctx->saved_data["relu"] = relu;
    // The output is kept only for the ReLU's mask.
    ctx->save_for_backward({x, weight, relu ? y : at::Tensor()});
    return y;
  }

  static variable_list backward(AutogradContext* ctx, variable_list grad_outputs) {
    const auto saved = ctx->get_saved_variables();
    const at::Tensor &x = saved[0], &weight = saved[1];
    at::Tensor g = grad_outputs[0].to(at::kBFloat16).contiguous(at::MemoryFormat::ChannelsLast);
    if (ctx->saved_data["relu"].toBool()) g = relu_masked<int16_t>(g, saved[2]);
    at::Tensor grad_input, grad_weight, grad_bias, grad_residual;
    if (ctx->needs_input_grad(0)) {
      // d(input) = the 'same' convolution of d(output) with w'[i][o][dy][dx] = w[o][i][2 - dy][2 - dx].
      const at::Tensor turned = weight.transpose(0, 1).flip({2, 3});
      grad_input = WinogradConv3x3(turned, {}, false, WinogradConv3x3::chosen_tiles()).forward(g, /*relu=*/false);
    }
    const bool need_weight = ctx->needs_input_grad(1), need_bias = ctx->needs_input_grad(2);
    if (need_weight || need_bias) {
      // Also by Winograd (winograd_weight_gradient.h), in float32 without a rounding to bf16.
      ConvParameterGradients grads = winograd_weight_gradient(x, g);
      if (need_weight) grad_weight = grads.weight;
      if (need_bias) grad_bias = grads.bias;
    }
    // The placeholder of a missing residual takes no gradient, so this asks for a real one only.
    if (ctx->needs_input_grad(3)) grad_residual = g;
    return {grad_input, grad_weight, grad_bias, grad_residual, at::Tensor()};
  }
};

}  // namespace

bool winograd_trains(const at::Tensor& input, const at::Tensor& weight) {
  if (input.scalar_type() != at::kBFloat16 || input.dim() != 4 || weight.dim() != 4 || weight.size(2) != 3 ||
      weight.size(3) != 3) {
    return false;
  }
  const int64_t outputs = weight.size(0), inputs = weight.size(1);
  return WinogradConv3x3::takes(outputs, inputs) && WinogradConv3x3::takes(inputs, outputs) &&
         winograd_weight_gradient_takes(outputs, inputs) &&
         WinogradConv3x3::available();
}

at::Tensor winograd_conv3x3_trained(const at::Tensor& input, const at::Tensor& weight, const at::Tensor& bias,
                                    const at::Tensor& residual, bool relu) {
  if (!winograd_trains(input, weight)) {
    fail("winograd_conv3x3_trained: needs a bf16 input and 3x3 weights of multiples of 64 channels on a CPU "
         "with AVX512_BF16");
  }
  const int64_t outputs = weight.size(0);
  // A residual of the wrong shape is refused by the convolution's own check (conv_destination.h).
  // A layer without bias gets a zero one, which takes no gradient.
  const at::Tensor b = bias.defined() ? bias : at::zeros({outputs}, weight.options());
  const at::Tensor r = residual.defined() ? residual : at::empty({0}, input.options());
  return WinogradConvFunction::apply(input, weight, b, r, relu);
}

}  // namespace lrf
