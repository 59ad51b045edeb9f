// The autoencoders' fused inference (onednn_conv.h, tiny_fused.h): one convolution with its residual add
// and ReLU against a float64 loop, and the tiny autoencoder's encode / decode / split decode against its
// torch modules, in fp32 and bf16, including weights that change after the first call.
#include <cmath>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "lrf/autoencoder/conv/narrow_conv.h"
#include "lrf/autoencoder/conv/onednn_conv.h"
#include "lrf/autoencoder/conv/winograd_conv.h"
#include "lrf/autoencoder/conv/winograd_training.h"
#include "lrf/autoencoder/conv/winograd_weight_gradient.h"
#include "lrf/autoencoder/mixed_layers.h"
#include "lrf/autoencoder/tiny_ae.h"
#include "lrf/autoencoder/tiny_block.h"
#include "lrf/autoencoder/tiny_fused.h"
#include "lrf/core/cpu_features.h"
#include "conv_reference.h"
#include "test_helpers.h"

namespace {

using lrf_test::channels_last;
using lrf_test::max_abs;
using lrf_test::reference_conv;

TEST(FusedConv2d, MatchesAFloat64LoopWithBiasResidualAndRelu) {
  torch::manual_seed(3);
  const at::Tensor x = torch::randn({2, 8, 11, 13});
  const at::Tensor w = torch::randn({6, 8, 3, 3}) * 0.3;
  const at::Tensor b = torch::randn({6});
  lrf::FusedConv2d conv(w, b, 1, 1);
  // float32: the sums of 72 products of O(1) terms, rounded in float32 in some order: 1e-4 is ~100 ulps
  // of the largest partial sums (~10).
  const at::Tensor plain = conv.forward(channels_last(x), false);
  EXPECT_TRUE(plain.is_contiguous(at::MemoryFormat::ChannelsLast));
  EXPECT_LT(max_abs(plain, reference_conv(x, w, b, 1, 1, {}, false)), 1e-4);
  EXPECT_LT(max_abs(conv.forward(channels_last(x), true), reference_conv(x, w, b, 1, 1, {}, true)), 1e-4);
  // The residual is added before the ReLU, into the tensor handed in, which is returned.
  const at::Tensor r = torch::randn({2, 6, 11, 13});
  at::Tensor into = channels_last(r.clone());
  const at::Tensor fused = conv.forward(channels_last(x), true, into);
  EXPECT_TRUE(fused.is_same(into));
  const at::Tensor want = reference_conv(x, w, b, 1, 1, r, true);
  EXPECT_LT(max_abs(fused, want), 1e-4);
  EXPECT_GT(want.eq(0).sum().item<int64_t>(), 0);  // the ReLU clipped something
  EXPECT_GT(max_abs(want, reference_conv(x, w, b, 1, 1, {}, true)), 0.5);  // and the residual mattered
}

TEST(FusedConv2d, StridedWithoutBiasAndInBf16) {
  torch::manual_seed(4);
  const at::Tensor x = torch::randn({1, 16, 17, 10});
  const at::Tensor w = torch::randn({16, 16, 3, 3}) * 0.2;
  lrf::FusedConv2d strided(w, {}, 2, 1);
  const at::Tensor y = strided.forward(channels_last(x), false);
  ASSERT_EQ(y.sizes(), (std::vector<int64_t>{1, 16, 9, 5}));
  EXPECT_LT(max_abs(y, reference_conv(x, w, {}, 2, 1, {}, false)), 1e-4);
  // bf16: inputs and weights rounded to 8 significant bits (relative 2^-9 each), float32 sums, the
  // output rounded once more. The reference takes the rounded inputs, so what is left is the output's
  // rounding (2^-9 of values up to ~6) plus the weights' (sums of 144 terms of ~0.2 with independent
  // errors of 2^-9 relative: ~0.01): 0.05 bounds both with margin, and is far below the values' spread.
  const at::Tensor x16 = channels_last(x.to(at::kBFloat16));
  const at::Tensor y16 = strided.forward(x16, false);
  EXPECT_EQ(y16.scalar_type(), at::kBFloat16);
  const at::Tensor want = reference_conv(x16.to(at::kFloat), w, {}, 2, 1, {}, false);
  EXPECT_LT(max_abs(y16, want), 0.05);
  EXPECT_GT(want.abs().max().item<double>(), 2.0);
}

TEST(UpsampledConv2d, EqualsAConvolutionOfTheUpsampledImage) {
  torch::manual_seed(7);
  const at::Tensor x = torch::randn({2, 8, 5, 7});
  const at::Tensor w = torch::randn({6, 8, 3, 3}) * 0.3;
  const at::Tensor b = torch::randn({6});
  const at::Tensor up = at::upsample_nearest2d(x, {10, 14});
  lrf::UpsampledConv2d conv(w, b);
  const at::Tensor y = conv.forward(channels_last(x), false);
  ASSERT_EQ(y.sizes(), (std::vector<int64_t>{2, 6, 10, 14}));
  EXPECT_TRUE(y.is_contiguous(at::MemoryFormat::ChannelsLast));
  // float32 sums of 32 products of summed weights, against float64: as in the plain convolution, 1e-4.
  EXPECT_LT(max_abs(y, reference_conv(up, w, b, 1, 1, {}, false)), 1e-4);
  EXPECT_LT(max_abs(conv.forward(channels_last(x), true), reference_conv(up, w, b, 1, 1, {}, true)), 1e-4);
  // Without bias and in bf16: the inputs exactly as given, the summed weights (up to 4 taps of ~0.3)
  // rounded to 2^-9 relative and the output rounded once: the 0.05 of the bf16 test above.
  lrf::UpsampledConv2d plain(w, {});
  const at::Tensor x16 = channels_last(x.to(at::kBFloat16));
  const at::Tensor want = reference_conv(at::upsample_nearest2d(x16.to(at::kFloat), {10, 14}), w, {}, 1, 1, {}, false);
  EXPECT_LT(max_abs(plain.forward(x16, false), want), 0.05);
  EXPECT_GT(want.abs().max().item<double>(), 2.0);
}

// Relative size of `got`'s error against `want`: root mean square, and largest over largest value.
using lrf_test::RelativeError;
using lrf_test::relative_error;

// Winograd in bf16 against float64 on the same bf16 inputs and the exact weights. What remains is the
// output's rounding (2^-9 relative at most, ~0.1 % rms) and the rounding of the transformed inputs and
// kernels (2^-9 relative each) in the 16 products, which the output transform adds with cancellation:
// measured ~0.45 % rms over 64 channels, against ~0.17 % for oneDNN's direct bf16 convolution. 2^-7 rms
// (0.78 %) and 2^-5 of the largest value bound that with margin; one wrong transform coefficient or a
// misplaced tile gives errors the size of the values themselves.
constexpr double kWinogradRms = 1.0 / 128, kWinogradMax = 1.0 / 32;
// F(3x3, 3x3)'s transforms have coefficients up to 8/3 and its output transform adds 25 products with more
// cancellation: measured 1.26 % rms and 2.4 % of the largest value on the 3x3 test below (a float64
// simulation of its roundings predicted 1.45 %); 2^-5 and 2^-4 bound that by ~2.5x.
constexpr double kWinograd3Rms = 1.0 / 32, kWinograd3Max = 1.0 / 16;

// What each Winograd test convolves: a bf16 channels-last input of `shape` = [N, I, H, W], weights of a
// trained layer's scale [outputs, I, 3, 3] and a bias, drawn from `seed`.
struct WinogradCase {
  at::Tensor x16, w, b;
};

WinogradCase winograd_case(uint64_t seed, const std::vector<int64_t>& shape, int64_t outputs) {
  torch::manual_seed(seed);
  WinogradCase c;
  c.x16 = channels_last(torch::randn(shape).to(at::kBFloat16));
  c.w = torch::randn({outputs, shape[1], 3, 3}) * 0.1;
  c.b = torch::randn({outputs});
  return c;
}

TEST(WinogradConv3x3, MatchesAFloat64LoopWithinBf16Rounding) {
  if (!lrf::WinogradConv3x3::available()) GTEST_SKIP() << "this CPU has no AVX512_BF16";
  // 29 columns: 15 tiles, a full unit of 12 and a short one of 3 with a partial last tile; 9 rows: a
  // partial last tile row.
  const WinogradCase c = winograd_case(11, {2, 32, 9, 29}, 64);
  const at::Tensor &x16 = c.x16, &w = c.w, &b = c.b;
  const lrf::WinogradConv3x3 conv(w, b);
  const at::Tensor y = conv.forward(x16, false);
  ASSERT_EQ(y.sizes(), (std::vector<int64_t>{2, 64, 9, 29}));
  EXPECT_EQ(y.scalar_type(), at::kBFloat16);
  EXPECT_TRUE(y.is_contiguous(at::MemoryFormat::ChannelsLast));
  const at::Tensor x = x16.to(at::kFloat);
  RelativeError e = relative_error(y, reference_conv(x, w, b, 1, 1, {}, false));
  EXPECT_LT(e.rms, kWinogradRms);
  EXPECT_LT(e.max, kWinogradMax);
  // The residual (read as bf16) is added before the ReLU, into the tensor handed in.
  const at::Tensor r16 = channels_last(torch::randn({2, 64, 9, 29}).to(at::kBFloat16));
  at::Tensor into = r16.clone(at::MemoryFormat::ChannelsLast);
  const at::Tensor fused = conv.forward(x16, true, into);
  EXPECT_TRUE(fused.is_same(into));
  const at::Tensor want = reference_conv(x, w, b, 1, 1, r16.to(at::kFloat), true);
  e = relative_error(fused, want);
  EXPECT_LT(e.rms, kWinogradRms);
  EXPECT_LT(e.max, kWinogradMax);
  EXPECT_GT(want.eq(0).sum().item<int64_t>(), 0);  // the ReLU clipped something
  // A single pixel: one tile whose 15 other taps are all padding.
  const at::Tensor dot16 = channels_last(torch::randn({1, 32, 1, 1}).to(at::kBFloat16));
  e = relative_error(conv.forward(dot16, false), reference_conv(dot16.to(at::kFloat), w, b, 1, 1, {}, false));
  EXPECT_LT(e.rms, kWinogradRms);
}

TEST(WinogradConv3x3, With3x3TilesMatchesAFloat64Loop) {
  if (!lrf::WinogradConv3x3::available()) GTEST_SKIP() << "this CPU has no AVX512_BF16";
  // 40 columns: 14 tiles, a full unit of 12 and one of 2 whose last tile has one column; 10 rows: a last
  // tile row of one.
  const WinogradCase c = winograd_case(14, {2, 64, 10, 40}, 128);
  const at::Tensor &x16 = c.x16, &w = c.w, &b = c.b;
  const lrf::WinogradConv3x3 conv(w, b, false, lrf::WinogradConv3x3::Tiles::f3x3);
  const at::Tensor r16 = channels_last(torch::randn({2, 128, 10, 40}).to(at::kBFloat16));
  at::Tensor into = r16.clone(at::MemoryFormat::ChannelsLast);
  const at::Tensor y = conv.forward(x16, true, into);
  ASSERT_EQ(y.sizes(), (std::vector<int64_t>{2, 128, 10, 40}));
  EXPECT_TRUE(y.is_same(into));
  const at::Tensor want = reference_conv(x16.to(at::kFloat), w, b, 1, 1, r16.to(at::kFloat), true);
  const RelativeError e = relative_error(y, want);
  EXPECT_LT(e.rms, kWinograd3Rms);
  EXPECT_LT(e.max, kWinograd3Max);
  EXPECT_GT(want.eq(0).sum().item<int64_t>(), 0);
  // A single pixel: one tile whose 24 other taps are all padding.
  const at::Tensor dot16 = channels_last(torch::randn({1, 64, 1, 1}).to(at::kBFloat16));
  EXPECT_LT(relative_error(conv.forward(dot16, false), reference_conv(dot16.to(at::kFloat), w, b, 1, 1, {}, false)).rms,
            kWinograd3Rms);
  // An upsampled input has 2x2 tiles only.
  EXPECT_NE(lrf::test::error_of([&] { lrf::WinogradConv3x3(w, b, true, lrf::WinogradConv3x3::Tiles::f3x3); })
                .find("2x2 tiles only"),
            std::string::npos);
}

TEST(WinogradConv3x3, FusedConv2dTakesItWhereTheCpuHasBf16AndOneDnnElsewhere) {
  if (!lrf::WinogradConv3x3::available()) GTEST_SKIP() << "this CPU has no AVX512_BF16";
  const WinogradCase c = winograd_case(12, {1, 64, 10, 14}, 64);
  const at::Tensor &x16 = c.x16, &w = c.w, &b = c.b;
  const lrf::FusedConv2d fused(w, b, 1, 1);
  const lrf::WinogradConv3x3 winograd(w, b, false, lrf::WinogradConv3x3::Tiles::f3x3);
  const at::Tensor by_winograd = winograd.forward(x16, true);
  EXPECT_TRUE(torch::equal(fused.forward(x16, true), by_winograd));
  {
    // $LRF_WINOGRAD_TILE=2 builds layers with 2x2 tiles, whose roundings differ; other values are refused.
    lrf::test::ScopedEnv two("LRF_WINOGRAD_TILE", "2");
    const at::Tensor by_2x2 = lrf::FusedConv2d(w, b, 1, 1).forward(x16, true);
    EXPECT_TRUE(torch::equal(by_2x2, lrf::WinogradConv3x3(w, b).forward(x16, true)));
    EXPECT_FALSE(torch::equal(by_2x2, by_winograd));
    lrf::test::ScopedEnv four("LRF_WINOGRAD_TILE", "4");
    EXPECT_NE(lrf::test::error_of([&] { lrf::FusedConv2d(w, b, 1, 1); }).find("LRF_WINOGRAD_TILE must be 2 or 3"),
              std::string::npos);
  }
  // fp32 inputs stay on oneDNN's direct convolution.
  const at::Tensor x = x16.to(at::kFloat);
  EXPECT_LT(max_abs(fused.forward(x, true), reference_conv(x, w, b, 1, 1, {}, true)), 1e-4);
  // A CPU without BF16: the direct bf16 convolution, whose result differs in its roundings.
  lrf::test::ScopedEnv no_bf16("LRF_CPU_BF16", "0");
  EXPECT_FALSE(lrf::WinogradConv3x3::available());
  const at::Tensor direct = fused.forward(x16, true);
  EXPECT_FALSE(torch::equal(direct, by_winograd));
  const RelativeError e = relative_error(direct, reference_conv(x, w, b, 1, 1, {}, true));
  EXPECT_LT(e.rms, kWinogradRms);
  EXPECT_NE(lrf::test::error_of([&] { winograd.forward(x16, false); }).find("AVX512_BF16"), std::string::npos);
}

TEST(WinogradConv3x3, OfAnUpsampledInputMatchesAFloat64Loop) {
  if (!lrf::WinogradConv3x3::available()) GTEST_SKIP() << "this CPU has no AVX512_BF16";
  // 15 columns: a unit of 12 tiles and one of 3; 5 rows; the output is 10x30.
  const WinogradCase c = winograd_case(13, {2, 32, 5, 15}, 64);
  const at::Tensor &x16 = c.x16, &w = c.w, &b = c.b;
  const lrf::WinogradConv3x3 conv(w, b, true);
  const at::Tensor y = conv.forward(x16, true);
  ASSERT_EQ(y.sizes(), (std::vector<int64_t>{2, 64, 10, 30}));
  EXPECT_TRUE(y.is_contiguous(at::MemoryFormat::ChannelsLast));
  const at::Tensor up = at::upsample_nearest2d(x16.to(at::kFloat), {10, 30});
  const at::Tensor want = reference_conv(up, w, b, 1, 1, {}, true);
  // The tolerances of the plain case: the same roundings, of fewer products.
  const RelativeError e = relative_error(y, want);
  EXPECT_LT(e.rms, kWinogradRms);
  EXPECT_LT(e.max, kWinogradMax);
  EXPECT_GT(want.eq(0).sum().item<int64_t>(), 0);
  // UpsampledConv2d takes this path in bf16.
  EXPECT_TRUE(torch::equal(lrf::UpsampledConv2d(w, b).forward(x16, true), y));
}

TEST(WinogradConv3x3, RefusesWhatItCannotRun) {
  EXPECT_TRUE(lrf::WinogradConv3x3::takes(64, 32));
  EXPECT_FALSE(lrf::WinogradConv3x3::takes(48, 64));  // outputs are accumulated 64 at a time
  EXPECT_FALSE(lrf::WinogradConv3x3::takes(64, 16));  // inputs are transformed 32 at a time
  EXPECT_NE(lrf::test::error_of([] { lrf::WinogradConv3x3(torch::randn({64, 32, 5, 5}), {}); }).find("[O, I, 3, 3]"),
            std::string::npos);
  EXPECT_NE(lrf::test::error_of([] { lrf::WinogradConv3x3(torch::randn({3, 32, 3, 3}), {}); }).find("multiple of 64"),
            std::string::npos);
  const lrf::WinogradConv3x3 conv(torch::randn({64, 32, 3, 3}), {});
  EXPECT_NE(lrf::test::error_of([&] { conv.forward(torch::randn({1, 32, 4, 4}), false); }).find("bf16"),
            std::string::npos);
  if (!lrf::WinogradConv3x3::available()) return;
  const at::Tensor x16 = channels_last(torch::randn({1, 32, 4, 4}).to(at::kBFloat16));
  EXPECT_NE(lrf::test::error_of([&] { conv.forward(x16, false, x16.clone()); }).find("residual"), std::string::npos);
}

// The direct bf16 convolution's roundings, against float64 on the same bf16 inputs: the weights' (2^-9
// relative each, independent) and the output's (at most 2^-9 of its value). Measured on the cases below
// 0.21-0.23 % rms and 0.24-0.28 % of the largest value, as oneDNN's direct kernel gives on them. The
// bounds of the Winograd tests, 2^-7 rms and 2^-5 of the largest value, hold that with margin; a tap
// taken from the wrong pixel or a lost pair of channels gives errors the size of the values.
constexpr double kDirectRms = kWinogradRms, kDirectMax = kWinogradMax;

TEST(NarrowConv3x3, MatchesAFloat64LoopForOneTwoAndThreeOutputs) {
  if (!lrf::NarrowConv3x3::available()) GTEST_SKIP() << "this CPU has no AVX512_BF16";
  // 21 columns: a group of 8 with the left padding, an inner group of 8, and a short group of 5 with the
  // right padding; 7 rows, the first and last against the padding; 2 images.
  for (int64_t outputs : {1, 2, 3}) {
    SCOPED_TRACE("outputs " + std::to_string(outputs));
    const WinogradCase c = winograd_case(20 + static_cast<uint64_t>(outputs), {2, 64, 7, 21}, outputs);
    const lrf::NarrowConv3x3 conv(c.w, c.b);
    const at::Tensor y = conv.forward(c.x16, false);
    ASSERT_EQ(y.sizes(), (std::vector<int64_t>{2, outputs, 7, 21}));
    EXPECT_EQ(y.scalar_type(), at::kBFloat16);
    EXPECT_TRUE(y.is_contiguous(at::MemoryFormat::ChannelsLast));
    const at::Tensor x = c.x16.to(at::kFloat);
    const RelativeError e = relative_error(y, reference_conv(x, c.w, c.b, 1, 1, {}, false));
    EXPECT_LT(e.rms, kDirectRms);
    EXPECT_LT(e.max, kDirectMax);
  }
  // The residual (read as bf16) is added before the ReLU, into the tensor handed in; 32 inputs; 16
  // columns, so that the second group of 8 ends at the right padding.
  const WinogradCase c = winograd_case(24, {1, 32, 4, 16}, 3);
  const lrf::NarrowConv3x3 conv(c.w, c.b);
  const at::Tensor r16 = channels_last(torch::randn({1, 3, 4, 16}).to(at::kBFloat16));
  at::Tensor into = r16.clone(at::MemoryFormat::ChannelsLast);
  EXPECT_TRUE(conv.forward(c.x16, true, into).is_same(into));
  const at::Tensor want = reference_conv(c.x16.to(at::kFloat), c.w, c.b, 1, 1, r16.to(at::kFloat), true);
  const RelativeError e = relative_error(into, want);
  EXPECT_LT(e.rms, kDirectRms);
  EXPECT_LT(e.max, kDirectMax);
  EXPECT_GT(want.eq(0).sum().item<int64_t>(), 0);  // the ReLU clipped something
  // A single pixel: eight of its nine taps are padding.
  const at::Tensor dot16 = channels_last(torch::randn({1, 32, 1, 1}).to(at::kBFloat16));
  const at::Tensor dot_want = reference_conv(dot16.to(at::kFloat), c.w, c.b, 1, 1, {}, false);
  EXPECT_LT(relative_error(conv.forward(dot16, false), dot_want).rms, kDirectRms);
}

TEST(NarrowConv3x3, FusedConv2dTakesItInBf16AndRefusesWhatItCannotRun) {
  EXPECT_TRUE(lrf::NarrowConv3x3::takes(3, 64));
  EXPECT_FALSE(lrf::NarrowConv3x3::takes(4, 64));  // 8 pixels x 3 outputs fill the registers
  EXPECT_FALSE(lrf::NarrowConv3x3::takes(3, 48));  // channels are multiplied 32 at a time
  EXPECT_NE(lrf::test::error_of([] { lrf::NarrowConv3x3(torch::randn({3, 64, 1, 1}), {}); }).find("[O, I, 3, 3]"),
            std::string::npos);
  EXPECT_NE(lrf::test::error_of([] { lrf::NarrowConv3x3(torch::randn({8, 64, 3, 3}), {}); }).find("1 to 3 outputs"),
            std::string::npos);
  const WinogradCase c = winograd_case(25, {1, 64, 6, 11}, 3);
  const lrf::NarrowConv3x3 narrow(c.w, c.b);
  EXPECT_NE(lrf::test::error_of([&] { narrow.forward(c.x16.to(at::kFloat), false); }).find("bf16"), std::string::npos);
  if (!lrf::NarrowConv3x3::available()) return;
  const lrf::FusedConv2d fused(c.w, c.b, 1, 1);
  EXPECT_EQ(fused.bf16_kernel(), lrf::FusedConv2d::Kernel::narrow);
  EXPECT_TRUE(torch::equal(fused.forward(c.x16, false), narrow.forward(c.x16, false)));
  EXPECT_EQ(lrf::FusedConv2d(torch::randn({4, 64, 3, 3}), {}, 1, 1).bf16_kernel(), lrf::FusedConv2d::Kernel::onednn);
  EXPECT_EQ(lrf::FusedConv2d(torch::randn({3, 64, 3, 3}), {}, 2, 1).bf16_kernel(),
            lrf::FusedConv2d::Kernel::onednn);  // strided
  // Switched off (as on a CPU without BF16): oneDNN's direct convolution.
  lrf::test::ScopedEnv off("LRF_FUSED_CONV", "0");
  EXPECT_FALSE(lrf::NarrowConv3x3::available());
  EXPECT_EQ(fused.bf16_kernel(), lrf::FusedConv2d::Kernel::onednn);
  const at::Tensor direct = fused.forward(c.x16, false);
  EXPECT_LT(relative_error(direct, reference_conv(c.x16.to(at::kFloat), c.w, c.b, 1, 1, {}, false)).rms, kDirectRms);
  EXPECT_NE(lrf::test::error_of([&] { narrow.forward(c.x16, false); }).find("AVX512_BF16"), std::string::npos);
}

// A training layer (float32 master weights) holding the case's weights and bias.
lrf::MixedConv2d layer_of(const WinogradCase& c) {
  lrf::MixedConv2d conv(torch::nn::Conv2dOptions(c.w.size(1), c.w.size(0), 3).padding(1));
  torch::NoGradGuard no_grad;
  conv->weight.copy_(c.w);
  conv->bias.copy_(c.b);
  return conv;
}

// Training in bf16 (winograd_training.h): MixedConv2d's forward, input, weight and bias gradients
// through Winograd, against float64. The upstream gradient is rounded to bf16 first, as a bf16 layer's
// backward rounds it, so what remains is the roundings the forward test bounds (the input gradient is
// the same Winograd convolution, of the transposed kernels; the weight and bias gradients, 2x2 tiles
// either way, are bounded in WinogradWeightGradient below): the forward's bounds for the tiles chosen,
// kWinogradRms and kWinogradMax for the weight and bias gradients. Run with either tile.
// Bounds of a forward-type pass (the forward and the input gradient) with the tiles $LRF_WINOGRAD_TILE
// chooses; the weight gradient has 2x2 tiles either way.
RelativeError forward_bounds() {
  return lrf::WinogradConv3x3::chosen_tiles() == lrf::WinogradConv3x3::Tiles::f3x3
             ? RelativeError{kWinograd3Rms, kWinograd3Max}
             : RelativeError{kWinogradRms, kWinogradMax};
}

// With `tile` as $LRF_WINOGRAD_TILE.
void check_mixed_conv_gradients(const char* tile) {
  lrf::test::ScopedEnv tiles("LRF_WINOGRAD_TILE", tile);
  const lrf::WinogradConv3x3::Tiles chosen = lrf::WinogradConv3x3::chosen_tiles();
  const RelativeError forward = forward_bounds(), weights{kWinogradRms, kWinogradMax};
  // 7x11: partial tiles in both directions.
  const WinogradCase c = winograd_case(14, {2, 64, 7, 11}, 64);
  lrf::MixedConv2d conv = layer_of(c);
  const at::Tensor x16 = c.x16.clone().requires_grad_(true);
  const at::Tensor up = channels_last(torch::randn({2, 64, 7, 11}).to(at::kBFloat16)).to(at::kFloat);
  const at::Tensor y = conv->forward(x16);
  EXPECT_EQ(y.scalar_type(), at::kBFloat16);
  // The forward is exactly the inference kernel's.
  EXPECT_TRUE(torch::equal(y.detach(), lrf::WinogradConv3x3(c.w, c.b, false, chosen).forward(c.x16, false)));
  y.backward(up.to(at::kBFloat16));

  // float64 reference: libtorch's double convolution and its autograd, on the same rounded input.
  const at::Tensor xd = c.x16.to(at::kDouble).requires_grad_(true);
  const at::Tensor wd = c.w.to(at::kDouble).requires_grad_(true), bd = c.b.to(at::kDouble).requires_grad_(true);
  const at::Tensor yd = at::conv2d(xd, wd, bd, 1, 1);
  yd.backward(up.to(at::kDouble));
  for (const auto& [got, want, bound] : std::vector<std::tuple<at::Tensor, at::Tensor, RelativeError>>{
           {y, yd, forward},
           {x16.grad(), xd.grad(), forward},
           {conv->weight.grad(), wd.grad(), weights},
           {conv->bias.grad(), bd.grad(), weights}}) {
    const RelativeError e = relative_error(got, want);
    EXPECT_LT(e.rms, bound.rms);
    EXPECT_LT(e.max, bound.max);
  }
  EXPECT_EQ(conv->weight.grad().scalar_type(), at::kFloat);  // the master weights' gradients stay float32
  // A layer without bias (as the decoder's after each upsampling) takes the same path.
  lrf::MixedConv2d plain(torch::nn::Conv2dOptions(64, 64, 3).padding(1).bias(false));
  {
    torch::NoGradGuard no_grad;
    plain->weight.copy_(c.w);
  }
  const at::Tensor y0 = plain->forward(x16);
  EXPECT_TRUE(torch::equal(y0.detach(), lrf::WinogradConv3x3(c.w, {}, false, chosen).forward(c.x16, false)));
  y0.backward(up.to(at::kBFloat16));
  EXPECT_TRUE(torch::equal(plain->weight.grad(), conv->weight.grad()));
  EXPECT_TRUE(relative_error(y, reference_conv(c.x16.to(at::kFloat), c.w, c.b, 1, 1, {}, false)).rms < forward.rms);

  // The float64 reference's gradients agree with central differences of the float64 loop: the loss
  // sum(up * conv) is linear in each entry, so the differences are exact but for float64 rounding.
  const at::Tensor upd = up.to(at::kDouble);
  auto loss = [&](const at::Tensor& x, const at::Tensor& w) {
    return (reference_conv(x, w, c.b, 1, 1, {}, false) * upd).sum().item<double>();
  };
  const at::Tensor x0 = c.x16.to(at::kDouble).contiguous(), w0 = c.w.to(at::kDouble).contiguous();
  for (int64_t i : {0L, 517L, 9855L}) {
    at::Tensor plus = x0.clone(), minus = x0.clone();
    plus.view(-1)[i] += 0.5;
    minus.view(-1)[i] -= 0.5;
    EXPECT_NEAR((loss(plus, w0) - loss(minus, w0)), xd.grad().reshape(-1)[i].item<double>(), 1e-9);
  }
  for (int64_t i : {3L, 20000L, 36863L}) {
    at::Tensor plus = w0.clone(), minus = w0.clone();
    plus.view(-1)[i] += 0.5;
    minus.view(-1)[i] -= 0.5;
    EXPECT_NEAR((loss(x0, plus) - loss(x0, minus)), wd.grad().reshape(-1)[i].item<double>(), 1e-9);
  }
}

TEST(WinogradTraining, MixedConv2dGradientsMatchFloat64) {
  if (!lrf::WinogradConv3x3::available()) GTEST_SKIP() << "Winograd not available here";
  check_mixed_conv_gradients("3");
}

TEST(WinogradTraining, MixedConv2dGradientsWith2x2TilesMatchFloat64) {
  if (!lrf::WinogradConv3x3::available()) GTEST_SKIP() << "Winograd not available here";
  check_mixed_conv_gradients("2");
}

// Training in bf16 on a CPU without native bf16 (mixed_layers.cpp): each convolution is a float32 one of
// the bf16 values of input, weight and bias, its output rounded to bf16 once; the gradients come back
// rounded to bf16 (the input's in bf16, the weight's and bias's as float32 holding bf16 values). Against
// float64 on the same bf16 values, what remains is that one rounding, at most 2^-9 of each value, and
// float32 sums far below it: bounds of 2^-9 rms and 2^-8 of the largest value. Reading the float32
// master weights unrounded, or a libtorch bf16 kernel rounding its partial sums, would add errors of
// the same size and break them. Strided, 1x1 and bias-free layers take the same path.
TEST(MixedConv2dWithoutNativeBf16, IsAFloat32ConvolutionOfTheBf16Values) {
  lrf::test::ScopedEnv no_bf16("LRF_CPU_BF16", "0");
  struct Layer {
    int64_t kernel, stride, pad;
    bool bias;
  };
  for (const Layer& l : {Layer{3, 1, 1, true}, Layer{3, 2, 1, false}, Layer{1, 1, 0, true}}) {
    SCOPED_TRACE("kernel " + std::to_string(l.kernel) + " stride " + std::to_string(l.stride));
    torch::manual_seed(31 + l.kernel + l.stride);
    lrf::MixedConv2d conv(
        torch::nn::Conv2dOptions(16, 24, l.kernel).stride(l.stride).padding(l.pad).bias(l.bias));
    {
      torch::NoGradGuard no_grad;
      conv->weight.copy_(torch::randn_like(conv->weight) * 0.2);
      if (l.bias) conv->bias.copy_(torch::randn_like(conv->bias));
    }
    const at::Tensor x16 = torch::randn({2, 16, 9, 13}).to(at::kBFloat16);
    const at::Tensor x = x16.clone().requires_grad_(true);
    const at::Tensor y = conv->forward(x);
    ASSERT_EQ(y.scalar_type(), at::kBFloat16);
    const at::Tensor up = torch::randn(y.sizes()).to(at::kBFloat16);
    y.backward(up);
    ASSERT_EQ(x.grad().scalar_type(), at::kBFloat16);
    ASSERT_EQ(conv->weight.grad().scalar_type(), at::kFloat);

    const at::Tensor w16 = conv->weight.detach().to(at::kBFloat16);
    const at::Tensor b16 = l.bias ? conv->bias.detach().to(at::kBFloat16) : at::Tensor();
    const at::Tensor xd = x16.to(at::kDouble).requires_grad_(true);
    const at::Tensor wd = w16.to(at::kDouble).requires_grad_(true);
    const at::Tensor bd = l.bias ? b16.to(at::kDouble).requires_grad_(true) : at::Tensor();
    const at::Tensor yd = at::conv2d(xd, wd, bd, l.stride, l.pad);
    yd.backward(up.to(at::kDouble));
    // libtorch's float64 convolution is the plain loop's, and its gradients are central differences of
    // the loop (the loss sum(up * conv) is linear in each entry, so they are exact but for rounding).
    EXPECT_LT(max_abs(yd, reference_conv(x16, w16, b16, l.stride, l.pad, {}, false)), 1e-12);
    const at::Tensor upd = up.to(at::kDouble);
    auto loss = [&](const at::Tensor& xs, const at::Tensor& ws) {
      return (reference_conv(xs, ws, b16, l.stride, l.pad, {}, false) * upd).sum().item<double>();
    };
    const at::Tensor x0 = x16.to(at::kDouble).contiguous(), w0 = w16.to(at::kDouble).contiguous();
    for (int64_t i : {0L, 1000L, x0.numel() - 1}) {
      at::Tensor plus = x0.clone(), minus = x0.clone();
      plus.view(-1)[i] += 0.5;
      minus.view(-1)[i] -= 0.5;
      EXPECT_NEAR(loss(plus, w0) - loss(minus, w0), xd.grad().reshape(-1)[i].item<double>(), 1e-9);
    }
    for (int64_t i : {0L, w0.numel() / 2, w0.numel() - 1}) {
      at::Tensor plus = w0.clone(), minus = w0.clone();
      plus.view(-1)[i] += 0.5;
      minus.view(-1)[i] -= 0.5;
      EXPECT_NEAR(loss(x0, plus) - loss(x0, minus), wd.grad().reshape(-1)[i].item<double>(), 1e-9);
    }

    std::vector<std::tuple<std::string, at::Tensor, at::Tensor>> pairs = {
        {"output", y, yd}, {"input gradient", x.grad(), xd.grad()}, {"weight gradient", conv->weight.grad(), wd.grad()}};
    if (l.bias) pairs.emplace_back("bias gradient", conv->bias.grad(), bd.grad());
    for (const auto& [what, got, want] : pairs) {
      const RelativeError e = relative_error(got, want);
      EXPECT_LT(e.rms, std::ldexp(1.0, -9)) << what;
      EXPECT_LT(e.max, std::ldexp(1.0, -8)) << what;
    }
  }
}

// A whole decoded view is wider than the 256-pixel tiles that keep oneDNN's AMX weight gradient right
// (mixed_layers.cpp): Winograd still runs all three passes of it (none of them is oneDNN's), within the
// same bounds against float64 as a small image.
TEST(WinogradTraining, ImagesWiderThanTheWeightGradientTilesStayOnWinograd) {
  if (!lrf::WinogradConv3x3::available()) GTEST_SKIP() << "Winograd not available here";
  const RelativeError forward = forward_bounds(), weights{kWinogradRms, kWinogradMax};
  const WinogradCase c = winograd_case(19, {1, 64, 5, 300}, 64);
  lrf::MixedConv2d conv = layer_of(c);
  const at::Tensor x16 = c.x16.clone().requires_grad_(true);
  const at::Tensor y = conv->forward(x16);
  EXPECT_TRUE(torch::equal(y.detach(), lrf::WinogradConv3x3(c.w, c.b, false, lrf::WinogradConv3x3::chosen_tiles())
                                           .forward(c.x16, false)));
  const at::Tensor up = channels_last(torch::randn({1, 64, 5, 300}).to(at::kBFloat16));
  y.backward(up);
  const at::Tensor xd = c.x16.to(at::kDouble).requires_grad_(true);
  const at::Tensor wd = c.w.to(at::kDouble).requires_grad_(true), bd = c.b.to(at::kDouble).requires_grad_(true);
  at::conv2d(xd, wd, bd, 1, 1).backward(up.to(at::kDouble));
  for (const auto& [got, want, bound] : std::vector<std::tuple<at::Tensor, at::Tensor, RelativeError>>{
           {x16.grad(), xd.grad(), forward}, {conv->weight.grad(), wd.grad(), weights}, {conv->bias.grad(), bd.grad(), weights}}) {
    const RelativeError e = relative_error(got, want);
    EXPECT_LT(e.rms, bound.rms);
    EXPECT_LT(e.max, bound.max);
  }
}

// A residual block's last convolution: relu(conv(x) + r), the add and the ReLU applied as the
// convolution stores, and in the backward the ReLU's mask applied as the gradient is read; the residual's
// gradient is that masked gradient. The mask is the derivative at the computed output, which is what
// the float64 backward is given (an output within rounding of 0 may have the other sign in float64: that
// is checked apart); then the tolerances above.
void check_residual_and_relu(const char* tile) {
  lrf::test::ScopedEnv tiles("LRF_WINOGRAD_TILE", tile);
  const lrf::WinogradConv3x3::Tiles chosen = lrf::WinogradConv3x3::chosen_tiles();
  const RelativeError forward = forward_bounds(), weights{kWinogradRms, kWinogradMax};
  const WinogradCase c = winograd_case(16, {2, 64, 9, 6}, 64);
  lrf::MixedConv2d conv = layer_of(c);
  const at::Tensor x16 = c.x16.clone().requires_grad_(true);
  const at::Tensor r16 = channels_last(torch::randn({2, 64, 9, 6}).to(at::kBFloat16)).requires_grad_(true);
  const at::Tensor up = channels_last(torch::randn({2, 64, 9, 6}).to(at::kBFloat16)).to(at::kFloat);
  const at::Tensor y = conv->forward_with(x16, r16, true);
  // The forward is the inference kernel's, residual and ReLU included; the caller's residual is unchanged.
  at::Tensor into = r16.detach().clone(at::MemoryFormat::ChannelsLast);
  EXPECT_TRUE(torch::equal(y.detach(), lrf::WinogradConv3x3(c.w, c.b, false, chosen).forward(c.x16, true, into)));
  y.backward(up.to(at::kBFloat16));

  const at::Tensor xd = c.x16.to(at::kDouble).requires_grad_(true), rd = r16.detach().to(at::kDouble).requires_grad_(true);
  const at::Tensor wd = c.w.to(at::kDouble).requires_grad_(true), bd = c.b.to(at::kDouble).requires_grad_(true);
  const at::Tensor before_relu = at::conv2d(xd, wd, bd, 1, 1) + rd;
  const at::Tensor mask = y.detach().gt(0);
  before_relu.backward(up.to(at::kDouble) * mask);
  const at::Tensor yd = before_relu.detach().relu();
  EXPECT_GT(yd.eq(0).sum().item<int64_t>(), 0);  // the ReLU clipped something
  // Where the mask and float64's sign disagree, the output is within the forward's tolerance of 0.
  const at::Tensor disagree = mask.ne(before_relu.detach().gt(0));
  EXPECT_LT(disagree.sum().item<int64_t>(), yd.numel() / 100);
  if (disagree.any().item<bool>()) {
    EXPECT_LT(before_relu.detach().masked_select(disagree).abs().max().item<double>(),
              forward.max * yd.abs().max().item<double>());
  }
  // The residual's gradient is the upstream one masked: exact but for the mask's disagreements.
  for (const auto& [got, want, bound] : std::vector<std::tuple<at::Tensor, at::Tensor, RelativeError>>{
           {y, yd, forward},
           {x16.grad(), xd.grad(), forward},
           {r16.grad(), rd.grad(), weights},
           {conv->weight.grad(), wd.grad(), weights},
           {conv->bias.grad(), bd.grad(), weights}}) {
    const RelativeError e = relative_error(got, want);
    EXPECT_LT(e.rms, bound.rms);
    EXPECT_LT(e.max, bound.max);
  }
  // Switched off, the same call is the plain layer's relu(conv + r).
  lrf::test::ScopedEnv off("LRF_WINOGRAD", "0");
  const at::Tensor direct = conv->forward_with(c.x16, r16.detach(), true);
  EXPECT_TRUE(torch::equal(direct, (conv->forward(c.x16) + r16.detach()).relu()));
}

TEST(WinogradTraining, ResidualAndReluInTheConvolutionMatchFloat64) {
  if (!lrf::WinogradConv3x3::available()) GTEST_SKIP() << "Winograd not available here";
  check_residual_and_relu("3");
}

TEST(WinogradTraining, ResidualAndReluWith2x2TilesMatchFloat64) {
  if (!lrf::WinogradConv3x3::available()) GTEST_SKIP() << "Winograd not available here";
  check_residual_and_relu("2");
}

// The weight and bias gradients by Winograd's transposed transforms, against float64 autograd on the
// same bf16 values. 13x21 pixels are 7x11 tiles, partial at the right and bottom edges; paired along
// rows, the last of each row has no partner, and the 42 pairs are a full chunk of 32 and one of 10;
// 128 inputs are two blocks of 64, and 160 outputs end in a short block of 4 after 26 of 6. Each transformed input and gradient is rounded
// to bf16 once (2^-9 relative) and the inverse kernel transform adds 16 of their products' sums with
// cancellation, as the forward's output transform does: the forward's bounds, kWinogradRms and
// kWinogradMax. A dropped tile, wrong sign or misplaced position gives errors of order 1.
TEST(WinogradWeightGradient, MatchesFloat64AutogradAndIsDeterministic) {
  if (!lrf::WinogradConv3x3::available()) GTEST_SKIP() << "Winograd not available here";
  const WinogradCase c = winograd_case(17, {1, 128, 13, 21}, 160);
  const at::Tensor g16 = channels_last(torch::randn({1, 160, 13, 21}).to(at::kBFloat16));
  const lrf::ConvParameterGradients got = lrf::winograd_weight_gradient(c.x16, g16);
  ASSERT_EQ(got.weight.sizes(), c.w.sizes());
  ASSERT_EQ(got.bias.sizes(), c.b.sizes());
  EXPECT_EQ(got.weight.scalar_type(), at::kFloat);

  const at::Tensor wd = c.w.to(at::kDouble).requires_grad_(true), bd = c.b.to(at::kDouble).requires_grad_(true);
  at::conv2d(c.x16.to(at::kDouble), wd, bd, 1, 1).backward(g16.to(at::kDouble));
  for (const auto& [mine, want] : {std::pair{got.weight, wd.grad()}, std::pair{got.bias, bd.grad()}}) {
    const RelativeError e = relative_error(mine, want);
    EXPECT_LT(e.rms, kWinogradRms);
    EXPECT_LT(e.max, kWinogradMax);
  }
  // The bias gradient is a plain sum of bf16 values in float32: far tighter than the bounds above.
  EXPECT_LT(relative_error(got.bias, bd.grad()).max, 1e-5);
  // Partial sums are added in a fixed order: the same inputs give the same bits.
  const lrf::ConvParameterGradients again = lrf::winograd_weight_gradient(c.x16, g16);
  EXPECT_TRUE(torch::equal(again.weight, got.weight));
  EXPECT_TRUE(torch::equal(again.bias, got.bias));
  // The float64 reference's weight gradient agrees with central differences of the float64 loop (the
  // loss Σ g · conv is linear in each weight, so they are exact but for float64 rounding).
  const at::Tensor x0 = c.x16.to(at::kDouble), gd = g16.to(at::kDouble), w0 = c.w.to(at::kDouble).contiguous();
  for (int64_t i : {0L, 4321L, 184319L}) {
    at::Tensor plus = w0.clone(), minus = w0.clone();
    plus.view(-1)[i] += 0.5;
    minus.view(-1)[i] -= 0.5;
    const double difference = ((reference_conv(x0, plus, c.b, 1, 1, {}, false) -
                                reference_conv(x0, minus, c.b, 1, 1, {}, false)) * gd).sum().item<double>();
    EXPECT_NEAR(difference, wd.grad().reshape(-1)[i].item<double>(), 1e-9);
  }
}

TEST(WinogradWeightGradient, RefusesWhatItCannotRun) {
  EXPECT_TRUE(lrf::winograd_weight_gradient_takes(32, 64));
  EXPECT_FALSE(lrf::winograd_weight_gradient_takes(64, 32));  // inputs are summed 64 at a time
  EXPECT_FALSE(lrf::winograd_weight_gradient_takes(16, 64));  // outputs are transformed 32 at a time
  const at::Tensor x = channels_last(torch::randn({1, 64, 6, 6}).to(at::kBFloat16));
  const at::Tensor g = channels_last(torch::randn({1, 64, 6, 5}).to(at::kBFloat16));
  EXPECT_NE(lrf::test::error_of([&] { lrf::winograd_weight_gradient(x, g); }).find("[1, 64, 6, 5]"),
            std::string::npos);
  EXPECT_NE(lrf::test::error_of([&] { lrf::winograd_weight_gradient(x.to(at::kFloat), x); }).find("bf16"),
            std::string::npos);
  const at::Tensor narrow = channels_last(torch::randn({1, 32, 6, 6}).to(at::kBFloat16));
  EXPECT_NE(lrf::test::error_of([&] { lrf::winograd_weight_gradient(narrow, x); }).find("multiple of 64"),
            std::string::npos);
}

// Without AVX512_BF16 (or with LRF_WINOGRAD=0) the same layer trains on libtorch's direct bf16
// convolution, whose roundings differ.
TEST(WinogradTraining, SwitchedOffTheLayerTrainsDirect) {
  if (!lrf::WinogradConv3x3::available()) GTEST_SKIP() << "Winograd not available here";
  const WinogradCase c = winograd_case(15, {1, 64, 6, 8}, 64);
  lrf::MixedConv2d conv = layer_of(c);
  const at::Tensor winograd = conv->forward(c.x16);
  lrf::test::ScopedEnv off("LRF_WINOGRAD", "0");
  const at::Tensor direct = conv->forward(c.x16);
  EXPECT_FALSE(torch::equal(direct, winograd));
  EXPECT_TRUE(torch::equal(direct, at::conv2d(c.x16, c.w.to(at::kBFloat16), c.b.to(at::kBFloat16), 1, 1)));
  EXPECT_FALSE(lrf::winograd_trains(c.x16, c.w));
  EXPECT_NE(lrf::test::error_of([&] { lrf::winograd_conv3x3_trained(c.x16, c.w, c.b); }).find("AVX512_BF16"),
            std::string::npos);
}

TEST(FusedConv2d, RefusesBadShapes) {
  lrf::FusedConv2d conv(torch::randn({4, 3, 3, 3}), torch::randn({4}), 1, 1);
  EXPECT_NE(lrf::test::error_of([&] { conv.forward(torch::randn({1, 5, 8, 8}), false); }).find("[N, 3, H, W]"),
            std::string::npos);
  const at::Tensor wrong = channels_last(torch::zeros({1, 4, 7, 8}));
  EXPECT_NE(lrf::test::error_of([&] { conv.forward(torch::randn({1, 3, 8, 8}), false, wrong); }).find("residual"),
            std::string::npos);
  EXPECT_NE(lrf::test::error_of([&] { conv.forward(torch::randn({1, 3, 8, 8}).to(at::kDouble), false); }).find("bf16"),
            std::string::npos);
  // A residual in the input's memory would be overwritten while it is read.
  lrf::FusedConv2d square(torch::randn({3, 3, 3, 3}), {}, 1, 1);
  const at::Tensor x = channels_last(torch::randn({1, 3, 8, 8}));
  EXPECT_NE(lrf::test::error_of([&] { square.forward(x, false, x); }).find("shares memory"), std::string::npos);
}

// A TAEF2-shaped network (32 latent channels, group-norm branches) with random weights, channels-last
// as load_autoencoder runs it.
std::unique_ptr<lrf::TinyAutoencoder> small_taef2() {
  torch::manual_seed(5);
  auto ae = std::make_unique<lrf::TinyAutoencoder>(32, true);
  ae->set_channels_last(true);
  return ae;
}

// The modules' result and the fused layers' result of `f`, computed with no gradient.
template <class F>
std::pair<at::Tensor, at::Tensor> both_ways(lrf::TinyAutoencoder& ae, F f) {
  torch::NoGradGuard no_grad;
  ae.set_fused_layers(false);
  at::Tensor modules = f();
  ae.set_fused_layers(true);
  at::Tensor fused = f();
  return {modules, fused};
}

double relative(const at::Tensor& a, const at::Tensor& b) {
  return max_abs(a, b) / std::max(1e-12, b.abs().max().item<double>());
}

TEST(TinyFusedLayers, Fp32AgreesWithTheModules) {
  auto ae = small_taef2();
  const at::Tensor x = torch::rand({1, 3, 64, 48});
  auto [z_modules, z_fused] = both_ways(*ae, [&] { return ae->encode(x); });
  ASSERT_EQ(z_fused.sizes(), z_modules.sizes());
  // Float32 throughout; only the order of the convolutions' sums differs (and one rounding per residual
  // add): 1e-4 of the output's range is ~800 ulps, against ~15 convolutions of 576 terms.
  EXPECT_LT(relative(z_fused, z_modules), 1e-4);
  auto [y_modules, y_fused] = both_ways(*ae, [&] { return ae->decode(z_modules); });
  EXPECT_LT(relative(y_fused, y_modules), 1e-4);
  // The split decode gives the whole decode's result, and leaves its input as it was.
  auto [unused, y_split] = both_ways(*ae, [&] {
    at::Tensor features = ae->decode_global(z_modules);
    const at::Tensor copy = features.clone();
    at::Tensor out = ae->decode_local(features);
    EXPECT_TRUE(features.equal(copy));
    return out;
  });
  (void)unused;
  EXPECT_LT(relative(ae->decode_unclamped(z_modules).detach(), y_split), 1e-4);
}

TEST(TinyFusedLayers, LeavesTheCallersTensorAlone) {
  // A block met first sees the caller's tensor (float32 channels-last needs no conversion): its residual
  // add must not write into it. (In the autoencoders every half starts with another layer; this is
  // run's own contract.)
  torch::manual_seed(6);
  torch::nn::Sequential layers(lrf::TinyBlock(16, false), lrf::TinyBlock(16, false));
  lrf::TinyFusedLayers fused;
  torch::NoGradGuard no_grad;
  const at::Tensor x = channels_last(torch::randn({1, 16, 12, 10}));
  const at::Tensor copy = x.clone();
  const at::Tensor y = fused.run(*layers, 0, layers->size(), x);
  EXPECT_TRUE(x.equal(copy));
  EXPECT_LT(relative(y, layers->forward(copy)), 1e-4);
}

TEST(TinyFusedLayers, FollowsWeightsThatChange) {
  auto ae = small_taef2();
  const at::Tensor z = torch::randn({1, 32, 6, 5});
  torch::NoGradGuard no_grad;
  const at::Tensor before = ae->decode_unclamped(z);
  // An optimiser step changes parameters in place: the fused layers must read them again.
  for (auto& p : ae->decoder_parameters()) p.mul_(1.05).add_(0.01);
  auto [modules, fused] = both_ways(*ae, [&] { return ae->decode_unclamped(z); });
  EXPECT_GT(max_abs(modules, before), 1e-3);
  EXPECT_LT(relative(fused, modules), 1e-4);
}

TEST(TinyFusedLayers, Bf16AgreesWithTheModules) {
  if (!lrf::cpu_has_bf16()) GTEST_SKIP() << "no native bf16 on this CPU";
  auto ae = small_taef2();
  ae->set_precision(lrf::Precision::bf16);
  const at::Tensor x = torch::rand({1, 3, 64, 48});
  auto [z_modules, z_fused] = both_ways(*ae, [&] { return ae->encode(x); });
  // Both round every activation to bf16 (2^-9 relative); they differ by the order of float32 sums and by
  // the rounding the fused residual add saves, each a fraction of one bf16 step per layer, compounded
  // over ~15 layers: a few bf16 steps of the output range, 3 % bounds it.
  EXPECT_LT(relative(z_fused, z_modules), 0.03);
  auto [y_modules, y_fused] = both_ways(*ae, [&] { return ae->decode(z_modules); });
  EXPECT_LT(relative(y_fused, y_modules), 0.03);
}

TEST(TinyFusedLayers, GradientsStillFlowThroughTheModules) {
  auto ae = small_taef2();
  ae->set_fused_layers(true);
  at::Tensor z = torch::randn({1, 32, 4, 4}, torch::requires_grad());
  at::Tensor y = ae->decode_unclamped(z);
  ASSERT_TRUE(y.requires_grad());
  y.sum().backward();
  EXPECT_GT(z.grad().abs().sum().item<double>(), 0);
}

}  // namespace
