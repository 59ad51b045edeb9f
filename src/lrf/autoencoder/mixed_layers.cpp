#include "lrf/autoencoder/mixed_layers.h"

#include <algorithm>
#include <vector>

#include <ATen/ATen.h>

#include "lrf/autoencoder/conv/winograd_training.h"
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

at::Tensor conv2d_in_tiles(const at::Tensor& input, const at::Tensor& weight, const at::Tensor& bias,
                           at::IntArrayRef stride, at::IntArrayRef padding, at::IntArrayRef dilation, int64_t groups,
                           int64_t tile) {
  if (tile < 1) fail("conv2d_in_tiles: the tile side must be positive");
  const auto dtype = input.scalar_type();
  const int64_t kh = weight.size(2), kw = weight.size(3);
  const at::Tensor padded = at::constant_pad_nd(input, {padding[1], padding[1], padding[0], padding[0]});
  const int64_t out_h = output_size(input.size(2), padding[0], kh, stride[0], dilation[0]);
  const int64_t out_w = output_size(input.size(3), padding[1], kw, stride[1], dilation[1]);
  std::vector<at::Tensor> rows;
  for (int64_t y0 = 0; y0 < out_h; y0 += tile) {
    const int64_t y1 = std::min(out_h, y0 + tile);
    std::vector<at::Tensor> tiles;
    for (int64_t x0 = 0; x0 < out_w; x0 += tile) {
      const int64_t x1 = std::min(out_w, x0 + tile);
      // The input window whose valid convolution is exactly output rows y0..y1-1, columns x0..x1-1.
      const at::Tensor window = padded.slice(2, y0 * stride[0], (y1 - 1) * stride[0] + dilation[0] * (kh - 1) + 1)
                                    .slice(3, x0 * stride[1], (x1 - 1) * stride[1] + dilation[1] * (kw - 1) + 1);
      // A cast per tile, so that each tile's weight gradient reaches a float32 parameter on its own.
      const at::Tensor w = weight.to(dtype);
      const at::Tensor b = bias.defined() ? bias.to(dtype) : bias;
      tiles.push_back(at::conv2d(window, w, b, stride, at::IntArrayRef({0, 0}), dilation, groups));
    }
    rows.push_back(tiles.size() == 1 ? tiles[0] : at::cat(tiles, 3));
  }
  const at::Tensor out = rows.size() == 1 ? rows[0] : at::cat(rows, 2);
  return out.contiguous(input.suggest_memory_format());
}

bool MixedConv2dImpl::runs_winograd(const at::Tensor& input) const {
  // Tiles come first: the weight gradient of a whole large image is what they keep from oneDNN on AMX.
  if (needs_tiles(input)) return false;
  const auto& pad = *c10::get<torch::ExpandingArray<2>>(options.padding());
  const auto& s = *options.stride();
  const auto& d = *options.dilation();
  return pad[0] == 1 && pad[1] == 1 && s[0] == 1 && s[1] == 1 && d[0] == 1 && d[1] == 1 && options.groups() == 1 &&
         winograd_trains(input, weight);
}

at::Tensor MixedConv2dImpl::forward(const at::Tensor& input) {
  if (needs_tiles(input)) {
    return conv2d_in_tiles(input, weight, bias, options.stride(), c10::get<torch::ExpandingArray<2>>(options.padding()),
                           options.dilation(), options.groups(), kWeightGradientTile);
  }
  if (runs_winograd(input)) return winograd_conv3x3_trained(input, weight, bias);
  const auto dtype = input.scalar_type();
  // Same dtype: no cast, so fp32 runs exactly the plain layer's arithmetic.
  at::Tensor w = weight.scalar_type() == dtype ? weight : weight.to(dtype);
  at::Tensor b = !bias.defined() || bias.scalar_type() == dtype ? bias : bias.to(dtype);
  return at::conv2d(input, w, b, options.stride(), c10::get<torch::ExpandingArray<2>>(options.padding()),
                    options.dilation(), options.groups());
}

at::Tensor MixedConv2dImpl::forward_with(const at::Tensor& input, const at::Tensor& residual, bool relu) {
  if (runs_winograd(input)) return winograd_conv3x3_trained(input, weight, bias, residual, relu);
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
