// conv2d_in_tiles (mixed_layers.h) against the whole convolution, in float64: values and the gradients
// of input, weight and bias, for the layer shapes the autoencoders use (3x3 stride 1 and 2, 1x1) and a
// dilated one, with tiles that divide the output, do not divide it, are one pixel, or cover it all.
#include <vector>

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "lrf/autoencoder/mixed_layers.h"

namespace {

struct Layer {
  int64_t kernel, stride, padding, dilation;
};

struct Result {
  at::Tensor out, d_input, d_weight, d_bias;
};

template <typename Conv>
Result run(const at::Tensor& input, const at::Tensor& weight, const at::Tensor& bias, const at::Tensor& d_out,
           Conv conv) {
  at::Tensor x = input.clone().requires_grad_(true), w = weight.clone().requires_grad_(true),
             b = bias.clone().requires_grad_(true);
  at::Tensor y = conv(x, w, b);
  y.backward(d_out);
  return {y.detach(), x.grad(), w.grad(), b.grad()};
}

double max_abs_diff(const at::Tensor& a, const at::Tensor& b) { return (a - b).abs().max().item<double>(); }

}  // namespace

TEST(TiledConvolution, EqualsTheWholeConvolutionWithItsGradients) {
  const auto f64 = at::TensorOptions().dtype(at::kDouble);
  for (const Layer& l : std::vector<Layer>{{3, 1, 1, 1}, {3, 2, 1, 1}, {1, 1, 0, 1}, {3, 1, 2, 2}}) {
    for (int64_t tile : {1, 4, 5, 100}) {
      SCOPED_TRACE("kernel " + std::to_string(l.kernel) + " stride " + std::to_string(l.stride) + " dilation " +
                   std::to_string(l.dilation) + " tile " + std::to_string(tile));
      torch::manual_seed(tile * 10 + l.stride);
      const at::Tensor input = torch::randn({2, 3, 11, 13}, f64);
      const at::Tensor weight = torch::randn({4, 3, l.kernel, l.kernel}, f64);
      const at::Tensor bias = torch::randn({4}, f64);
      const std::vector<int64_t> stride{l.stride, l.stride}, padding{l.padding, l.padding},
          dilation{l.dilation, l.dilation};
      auto whole = [&](const at::Tensor& x, const at::Tensor& w, const at::Tensor& b) {
        return at::conv2d(x, w, b, stride, padding, dilation, 1);
      };
      const at::Tensor d_out = torch::randn(whole(input, weight, bias).sizes(), f64);
      const Result expected = run(input, weight, bias, d_out, whole);
      const Result tiled = run(input, weight, bias, d_out, [&](const at::Tensor& x, const at::Tensor& w, const at::Tensor& b) {
        return lrf::conv2d_in_tiles(x, w, b, stride, padding, dilation, 1, tile);
      });
      ASSERT_EQ(tiled.out.sizes(), expected.out.sizes());
      // Sums of at most 3x3x3 products per output and 2x13x11 per weight: float64 agrees to ~1e-15.
      EXPECT_LT(max_abs_diff(tiled.out, expected.out), 1e-12);
      EXPECT_LT(max_abs_diff(tiled.d_input, expected.d_input), 1e-12);
      EXPECT_LT(max_abs_diff(tiled.d_weight, expected.d_weight), 1e-12);
      EXPECT_LT(max_abs_diff(tiled.d_bias, expected.d_bias), 1e-12);
    }
  }
}
