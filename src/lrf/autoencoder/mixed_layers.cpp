#include "lrf/autoencoder/mixed_layers.h"

#include <algorithm>
#include <vector>

#include <ATen/ATen.h>
#include <torch/autograd.h>

#include "lrf/autoencoder/conv/winograd_f32.h"
#include "lrf/autoencoder/conv/winograd_training.h"
#include "lrf/core/cpu_features.h"
#include "lrf/core/error.h"

namespace lrf {

MixedConv2dImpl::MixedConv2dImpl(const torch::nn::Conv2dOptions& options) : torch::nn::Conv2dImpl(options) {
  if (!c10::holds_alternative<torch::ExpandingArray<2>>(options.padding()) ||
      !c10::holds_alternative<torch::enumtype::kZeros>(options.padding_mode())) {
    fail("MixedConv2d: only explicit zero padding is supported");
  }
}

namespace {

// oneDNN's bf16 weight-gradient kernels on AMX (the libtorch 1.13 of Debian 12) are wrong for large
// images, measured on a 64->64 3x3 layer against fp32: above about 112,000 pixels (320x350 right,
// 336x336 and fern's 504x376 wrong: relative error 1.4, NaN for 3 output channels) and for wide ones
// (128x512 wrong); 64x768 never returns. 256x256 (also 512x128, 1024x64) agrees to bf16's rounding
// (relative error 0.003) at 1 and 2 threads. So a training convolution in bf16 is run on output tiles
// no larger than this: the same convolution, whose tiles' weight gradients add up in float32.
constexpr int64_t kWeightGradientTile = 256;

int64_t output_size(int64_t in, int64_t pad, int64_t kernel, int64_t stride, int64_t dilation) {
  return (in + 2 * pad - dilation * (kernel - 1) - 1) / stride + 1;
}

}  // namespace

bool MixedConv2dImpl::needs_tiles(const at::Tensor& input) const {
  if (input.scalar_type() != at::kBFloat16 || !at::GradMode::is_enabled() || !weight.requires_grad()) return false;
  const auto& pad = c10::get<torch::ExpandingArray<2>>(options.padding());
  const auto& k = options.kernel_size();
  const auto& s = options.stride();
  const auto& d = options.dilation();
  return output_size(input.size(2), (*pad)[0], (*k)[0], (*s)[0], (*d)[0]) > kWeightGradientTile ||
         output_size(input.size(3), (*pad)[1], (*k)[1], (*s)[1], (*d)[1]) > kWeightGradientTile;
}

namespace {

using torch::autograd::AutogradContext;
using torch::autograd::variable_list;

// The convolution's forward whole, its gradients tile by tile: each output tile's valid convolution of
// its input window gives that window's input gradient (added into one buffer of the padded input) and
// the tile's share of the weight gradient. Written as one autograd function rather than as slices of the
// input: each slice's backward allocates and zeroes a gradient of the whole padded input and adds it up,
// which for a decoded 504x376 view cost more than the convolution itself.
class TiledConvFunction : public torch::autograd::Function<TiledConvFunction> {
 public:
  // `bias`: a tensor of no elements for none (autograd::Function takes no undefined inputs).
  static at::Tensor forward(AutogradContext* ctx, const at::Tensor& input, const at::Tensor& weight,
                            const at::Tensor& bias, std::vector<int64_t> stride, std::vector<int64_t> padding,
                            std::vector<int64_t> dilation, int64_t groups, int64_t tile) {
    const auto dtype = input.scalar_type();
    const at::Tensor w = weight.to(dtype);
    const at::Tensor b = bias.numel() > 0 ? bias.to(dtype) : at::Tensor();
    ctx->save_for_backward({input, weight, bias});
    ctx->saved_data["stride"] = stride;
    ctx->saved_data["padding"] = padding;
    ctx->saved_data["dilation"] = dilation;
    ctx->saved_data["groups"] = groups;
    ctx->saved_data["tile"] = tile;
    return at::conv2d(input, w, b, stride, padding, dilation, groups);
  }

  static variable_list backward(AutogradContext* ctx, variable_list grad_outputs) {
    const auto saved = ctx->get_saved_variables();
    const at::Tensor &input = saved[0], &weight = saved[1], &bias = saved[2];
    const std::vector<int64_t> stride = ctx->saved_data["stride"].toIntVector();
    const std::vector<int64_t> padding = ctx->saved_data["padding"].toIntVector();
    const std::vector<int64_t> dilation = ctx->saved_data["dilation"].toIntVector();
    const int64_t groups = ctx->saved_data["groups"].toInt(), tile = ctx->saved_data["tile"].toInt();
    const bool need_input = ctx->needs_input_grad(0), need_weight = ctx->needs_input_grad(1);
    const at::Tensor g = grad_outputs[0].to(input.scalar_type());
    const at::Tensor w = weight.to(input.scalar_type());
    const int64_t kh = weight.size(2), kw = weight.size(3);
    const at::Tensor padded = at::constant_pad_nd(input, {padding[1], padding[1], padding[0], padding[0]});
    at::Tensor grad_padded, grad_weight, grad_bias;
    if (need_input) grad_padded = at::zeros_like(padded);
    if (need_weight) grad_weight = at::zeros_like(weight, at::MemoryFormat::Contiguous);
    for (int64_t y0 = 0; (need_input || need_weight) && y0 < g.size(2); y0 += tile) {
      const int64_t y1 = std::min(g.size(2), y0 + tile);
      const int64_t wy0 = y0 * stride[0], wy1 = (y1 - 1) * stride[0] + dilation[0] * (kh - 1) + 1;
      for (int64_t x0 = 0; x0 < g.size(3); x0 += tile) {
        const int64_t x1 = std::min(g.size(3), x0 + tile);
        const int64_t wx0 = x0 * stride[1], wx1 = (x1 - 1) * stride[1] + dilation[1] * (kw - 1) + 1;
        // The input window whose valid convolution is exactly output rows y0..y1-1, columns x0..x1-1.
        const at::Tensor window = padded.slice(2, wy0, wy1).slice(3, wx0, wx1);
        const auto grads = at::convolution_backward(g.slice(2, y0, y1).slice(3, x0, x1), window, w, c10::nullopt,
                                                    stride, {0, 0}, dilation, false, {0, 0}, groups,
                                                    {need_input, need_weight, false});
        if (need_input) grad_padded.slice(2, wy0, wy1).slice(3, wx0, wx1).add_(std::get<0>(grads));
        // Each tile's weight gradient reaches the (float32) parameter's precision before the tiles add up.
        if (need_weight) grad_weight.add_(std::get<1>(grads).to(weight.scalar_type()));
      }
    }
    at::Tensor grad_input;
    if (need_input) {
      grad_input = grad_padded.slice(2, padding[0], padding[0] + input.size(2))
                       .slice(3, padding[1], padding[1] + input.size(3))
                       .contiguous(input.suggest_memory_format());
    }
    if (bias.numel() > 0 && ctx->needs_input_grad(2)) grad_bias = g.sum({0, 2, 3}, false, bias.scalar_type());
    return {grad_input, grad_weight, grad_bias, at::Tensor(), at::Tensor(), at::Tensor(), at::Tensor(), at::Tensor()};
  }
};

}  // namespace

at::Tensor conv2d_in_tiles(const at::Tensor& input, const at::Tensor& weight, const at::Tensor& bias,
                           at::IntArrayRef stride, at::IntArrayRef padding, at::IntArrayRef dilation, int64_t groups,
                           int64_t tile) {
  if (tile < 1) fail("conv2d_in_tiles: the tile side must be positive");
  const at::Tensor b = bias.defined() ? bias : at::empty({0}, weight.options());
  const at::Tensor out = TiledConvFunction::apply(input, weight, b, stride.vec(), padding.vec(), dilation.vec(), groups,
                                                  tile);
  return out.contiguous(input.suggest_memory_format());
}

bool MixedConv2dImpl::is_same_3x3() const {
  const auto& pad = *c10::get<torch::ExpandingArray<2>>(options.padding());
  const auto& s = *options.stride();
  const auto& d = *options.dilation();
  const auto& k = *options.kernel_size();
  return k[0] == 3 && k[1] == 3 && pad[0] == 1 && pad[1] == 1 && s[0] == 1 && s[1] == 1 && d[0] == 1 && d[1] == 1 &&
         options.groups() == 1;
}

bool MixedConv2dImpl::runs_winograd(const at::Tensor& input) const {
  // Whatever the image's size: Winograd's three passes are the project's own kernels, so oneDNN's weight
  // gradient, which the tiles guard against on AMX, never runs for them (and a whole decoded view's tiles
  // cost the step three times its convolutions in slices and their zero-filled gradients).
  return is_same_3x3() && winograd_trains(input, weight);
}

at::Tensor MixedConv2dImpl::forward(const at::Tensor& input) {
  if (runs_winograd(input)) return winograd_conv3x3_trained(input, weight, bias);
  if (is_same_3x3() && winograd_f32_trains(input, weight)) return winograd_f32_conv3x3_trained(input, weight, bias);
  if (input.scalar_type() == at::kBFloat16 && !cpu_has_bf16()) {
    // Without native bf16, oneDNN has no bf16 convolution (AVX2) or emulates one, and libtorch's
    // reference kernels run the backward about 40x slower than fp32 (bench_autoencoder backward on a
    // 2-core EPYC with AVX2). So the bf16 values of input, weight and bias are convolved in float32 and
    // the output rounded to bf16 once: the arithmetic of a native bf16 layer (products of bf16 values,
    // float32 sums) at fp32's cost. Autograd carries the casts: the input gradient comes back in bf16,
    // the weight's in float32, each from float32 convolutions of bf16-rounded tensors.
    const at::Tensor w = weight.to(at::kBFloat16).to(at::kFloat);
    const at::Tensor b = bias.defined() ? bias.to(at::kBFloat16).to(at::kFloat) : bias;
    return at::conv2d(input.to(at::kFloat), w, b, options.stride(), c10::get<torch::ExpandingArray<2>>(options.padding()),
                      options.dilation(), options.groups())
        .to(at::kBFloat16);
  }
  if (needs_tiles(input)) {
    return conv2d_in_tiles(input, weight, bias, options.stride(), c10::get<torch::ExpandingArray<2>>(options.padding()),
                           options.dilation(), options.groups(), kWeightGradientTile);
  }
  const auto dtype = input.scalar_type();
  // Same dtype: no cast, so fp32 runs exactly the plain layer's arithmetic.
  at::Tensor w = weight.scalar_type() == dtype ? weight : weight.to(dtype);
  at::Tensor b = !bias.defined() || bias.scalar_type() == dtype ? bias : bias.to(dtype);
  return at::conv2d(input, w, b, options.stride(), c10::get<torch::ExpandingArray<2>>(options.padding()),
                    options.dilation(), options.groups());
}

at::Tensor MixedConv2dImpl::forward_with(const at::Tensor& input, const at::Tensor& residual, bool relu) {
  if (runs_winograd(input)) return winograd_conv3x3_trained(input, weight, bias, residual, relu);
  if (is_same_3x3() && winograd_f32_trains(input, weight)) {
    return winograd_f32_conv3x3_trained(input, weight, bias, residual, relu);
  }
  at::Tensor y = forward(input);
  if (residual.defined()) y = y + residual;
  // In place: a convolution's backward does not need its output, nor an add's.
  return relu ? y.relu_() : y;
}

MixedGroupNormImpl::MixedGroupNormImpl(const torch::nn::GroupNormOptions& options)
    : torch::nn::GroupNormImpl(options) {}

at::Tensor MixedGroupNormImpl::forward(const at::Tensor& input) {
  if (input.scalar_type() == at::kFloat) return torch::nn::GroupNormImpl::forward(input);
  return torch::nn::GroupNormImpl::forward(input.to(at::kFloat)).to(input.scalar_type());
}

}  // namespace lrf
