// The float32 Winograd convolution (winograd_f32.h) on every vector width this CPU has (AVX2 and, where
// present, AVX-512F, chosen with $LRF_CPU_ISA) and every tile size: values against a float64 loop, and
// the input, weight and bias gradients against float64 autograd, whose own gradients are checked against
// central differences of the loop.
#include <cstdio>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "conv_reference.h"
#include "lrf/autoencoder/autoencoder.h"
#include "lrf/autoencoder/image_tensor.h"
#include "lrf/autoencoder/conv/onednn_conv.h"
#include "lrf/autoencoder/conv/winograd_f32.h"
#include "lrf/autoencoder/conv/winograd_weight_gradient.h"
#include "lrf/autoencoder/mixed_layers.h"
#include "lrf/core/cpu_features.h"
#include "lrf/core/image_io.h"
#include "lrf/eval/metrics.h"
#include "reference_helper.h"
#include "test_helpers.h"

namespace {

using lrf_test::channels_last;
using lrf_test::reference_conv;
using lrf_test::relative_error;
using lrf_test::RelativeError;

// The instruction sets to run here: every one of avx2 and avx512 that this CPU has.
std::vector<std::string> levels() {
  std::vector<std::string> out;
  if (lrf::cpu_simd_level() >= lrf::SimdLevel::avx2) out.push_back("avx2");
  if (lrf::cpu_simd_level() >= lrf::SimdLevel::avx512) out.push_back("avx512");
  return out;
}

// float32 Winograd against float64. The direct float32 convolution leaves ~1e-7 of the values (rms);
// the transforms multiply inputs by up to 5 and outputs by up to 8 (F(4x4)) and the output transform
// adds 36 products with cancellation: F(4x4) measures 0.7-1.0e-6 rms and 2-3e-6 of the largest value on
// these cases, F(2x2) 1.3-2.1e-7 (every gradient included), F(6x6) (coefficients up to 32) 1.4-2.4e-6 rms
// and 2.6-6.7e-6 of the largest value. 1e-5 rms and 3e-5 of the largest value leave 10x for F(4x4) and
// 4x for F(6x6); one wrong coefficient, a misplaced tile or a lost border gives errors of the order of the
// values.
constexpr double kRms = 1e-5, kMax = 3e-5;

struct Case {
  at::Tensor x, w, b;
};

Case make_case(int64_t seed, std::vector<int64_t> input, int64_t outputs) {
  torch::manual_seed(seed);
  Case c;
  c.x = channels_last(torch::randn(input));
  c.w = torch::randn({outputs, input[1], 3, 3}) * 0.2;
  c.b = torch::randn({outputs});
  return c;
}

void expect_close(const at::Tensor& got, const at::Tensor& want, const std::string& what) {
  const RelativeError e = relative_error(got, want);
  std::printf("%-40s rms %.2g, max %.2g\n", what.c_str(), e.rms, e.max);
  EXPECT_LT(e.rms, kRms) << what;
  EXPECT_LT(e.max, kMax) << what;
}

}  // namespace

TEST(WinogradF32, ForwardMatchesAFloat64LoopOnEveryWidthAndTile) {
  const auto isas = levels();
  if (isas.empty()) GTEST_SKIP() << "this CPU has no AVX2 with FMA";
  for (const auto& isa : isas) {
    lrf::test::ScopedEnv cap("LRF_CPU_ISA", isa.c_str());
    for (int tile : {2, 4, 6}) {
      const std::string what = isa + ", tile " + std::to_string(tile);
      // 9x13: partial tiles on both sides, and a second image.
      const Case c = make_case(3, {2, 16, 9, 13}, 32);
      ASSERT_TRUE(lrf::WinogradF32Conv3x3::runs(32, 16)) << what;
      const lrf::WinogradF32Conv3x3 conv(c.w, c.b, false, tile);
      const at::Tensor y = conv.forward(c.x, false);
      EXPECT_TRUE(y.is_contiguous(at::MemoryFormat::ChannelsLast));
      expect_close(y, reference_conv(c.x, c.w, c.b, 1, 1, {}, false), what);
      // With a residual and the ReLU, written into the residual.
      const at::Tensor r = channels_last(torch::randn({2, 32, 9, 13}));
      const at::Tensor want = reference_conv(c.x, c.w, c.b, 1, 1, r, true);
      at::Tensor into = r.clone();
      const at::Tensor got = conv.forward(c.x, true, into);
      EXPECT_EQ(got.data_ptr(), into.data_ptr());
      expect_close(got, want, what + ", residual and ReLU");
      // Of the input upsampled 2x, read in place.
      const lrf::WinogradF32Conv3x3 up(c.w, c.b, true, tile);
      const at::Tensor x2 = at::upsample_nearest2d(c.x, {18, 26});
      expect_close(up.forward(c.x, true), reference_conv(x2, c.w, c.b, 1, 1, {}, true), what + ", upsampled");
    }
  }
}

TEST(WinogradF32, GradientsMatchFloat64OnEveryWidthAndTile) {
  const auto isas = levels();
  if (isas.empty()) GTEST_SKIP() << "this CPU has no AVX2 with FMA";
  const Case c = make_case(5, {2, 16, 11, 7}, 32);
  const at::Tensor up = channels_last(torch::randn({2, 32, 11, 7}));
  // float64 reference: libtorch's double convolution and its autograd.
  const at::Tensor xd = c.x.to(at::kDouble).requires_grad_(true);
  const at::Tensor wd = c.w.to(at::kDouble).requires_grad_(true), bd = c.b.to(at::kDouble).requires_grad_(true);
  at::conv2d(xd, wd, bd, 1, 1).backward(up.to(at::kDouble));
  for (const auto& isa : isas) {
    lrf::test::ScopedEnv cap("LRF_CPU_ISA", isa.c_str());
    for (const char* tile : {"2", "4", "6"}) {
      lrf::test::ScopedEnv tiles("LRF_WINOGRAD_F32_TILE", tile);
      const std::string what = isa + ", tile " + tile;
      const at::Tensor x = c.x.clone().requires_grad_(true);
      const at::Tensor w = c.w.clone().requires_grad_(true), b = c.b.clone().requires_grad_(true);
      ASSERT_TRUE(lrf::winograd_f32_trains(x, w)) << what;
      const at::Tensor y = lrf::winograd_f32_conv3x3_trained(x, w, b);
      y.backward(up);
      expect_close(y, reference_conv(c.x, c.w, c.b, 1, 1, {}, false), what + ", forward");
      expect_close(x.grad(), xd.grad(), what + ", input gradient");
      expect_close(w.grad(), wd.grad(), what + ", weight gradient");
      expect_close(b.grad(), bd.grad(), what + ", bias gradient");
      EXPECT_EQ(w.grad().scalar_type(), at::kFloat);
      // With a residual and the ReLU applied as the outputs are stored, and the ReLU's mask in the backward.
      const at::Tensor r = c.x.narrow(1, 0, 16).repeat({1, 2, 1, 1}).clone().requires_grad_(true);
      const at::Tensor x2 = c.x.clone().requires_grad_(true), w2 = c.w.clone().requires_grad_(true);
      lrf::winograd_f32_conv3x3_trained(x2, w2, {}, r, true).backward(up);
      const at::Tensor rd = r.detach().to(at::kDouble).requires_grad_(true);
      const at::Tensor xd2 = c.x.to(at::kDouble).requires_grad_(true), wd2 = c.w.to(at::kDouble).requires_grad_(true);
      (at::conv2d(xd2, wd2, {}, 1, 1) + rd).relu().backward(up.to(at::kDouble));
      expect_close(x2.grad(), xd2.grad(), what + ", residual and ReLU: input gradient");
      expect_close(w2.grad(), wd2.grad(), what + ", residual and ReLU: weight gradient");
      expect_close(r.grad(), rd.grad(), what + ", residual and ReLU: residual gradient");
      // The weight gradient alone, as the training layer calls it, is deterministic at a thread count.
      const lrf::ConvParameterGradients once = lrf::winograd_f32_weight_gradient(c.x, up, std::stoi(tile));
      EXPECT_TRUE(torch::equal(once.weight, lrf::winograd_f32_weight_gradient(c.x, up, std::stoi(tile)).weight));
    }
  }
  // The float64 reference's gradients agree with central differences of the float64 loop (the loss is
  // linear in each entry, so the differences are exact but for float64 rounding).
  const at::Tensor upd = up.to(at::kDouble);
  auto loss = [&](const at::Tensor& x, const at::Tensor& w) {
    return (reference_conv(x, w, c.b, 1, 1, {}, false) * upd).sum().item<double>();
  };
  const at::Tensor x0 = c.x.to(at::kDouble).contiguous(), w0 = c.w.to(at::kDouble).contiguous();
  for (int64_t i : {0L, 301L, 2463L}) {
    at::Tensor plus = x0.clone(), minus = x0.clone();
    plus.view(-1)[i] += 0.5;
    minus.view(-1)[i] -= 0.5;
    EXPECT_NEAR(loss(plus, w0) - loss(minus, w0), xd.grad().reshape(-1)[i].item<double>(), 1e-9);
  }
  for (int64_t i : {2L, 1000L, 4607L}) {
    at::Tensor plus = w0.clone(), minus = w0.clone();
    plus.view(-1)[i] += 0.5;
    minus.view(-1)[i] -= 0.5;
    EXPECT_NEAR(loss(x0, plus) - loss(x0, minus), wd.grad().reshape(-1)[i].item<double>(), 1e-9);
  }
}

TEST(WinogradF32, LayersTakeItWhereItRunsAndTheCapTurnsItOff) {
  if (levels().empty()) GTEST_SKIP() << "this CPU has no AVX2 with FMA";
  const Case c = make_case(7, {1, 16, 10, 12}, 16);
  const at::Tensor want = reference_conv(c.x, c.w, c.b, 1, 1, {}, true);
  lrf::MixedConv2d layer(torch::nn::Conv2dOptions(16, 16, 3).padding(1));
  {
    torch::NoGradGuard no_grad;
    layer->weight.copy_(c.w);
    layer->bias.copy_(c.b);
  }
  const lrf::FusedConv2d fused(c.w, c.b, 1, 1);
  const at::Tensor winograd = lrf::WinogradF32Conv3x3(c.w, c.b).forward(c.x, false);
  // Inference and training layers run the Winograd kernel: the same bits as calling it.
  EXPECT_TRUE(torch::equal(layer->forward(c.x).contiguous(), winograd.contiguous()));
  EXPECT_TRUE(torch::equal(fused.forward(c.x, false).contiguous(), winograd.contiguous()));
  // Capped to baseline x86-64 (or switched off), the same layers run oneDNN's direct convolution.
  for (const auto& [name, value] : std::vector<std::pair<const char*, const char*>>{{"LRF_CPU_ISA", "baseline"},
                                                                                     {"LRF_WINOGRAD", "0"}}) {
    lrf::test::ScopedEnv off(name, value);
    EXPECT_FALSE(lrf::WinogradF32Conv3x3::runs(16, 16)) << name;
    const at::Tensor direct = fused.forward(c.x, true);
    EXPECT_FALSE(torch::equal(direct.contiguous(), winograd.relu().contiguous())) << name;
    expect_close(direct, want, name);
    expect_close(layer->forward(c.x).relu(), want, name);
  }
  // Channel counts that are not multiples of the lanes are not taken.
  EXPECT_FALSE(lrf::WinogradF32Conv3x3::runs(16, 4));
  EXPECT_FALSE(lrf::WinogradF32Conv3x3::runs(3, 64));
}

TEST(WinogradF32, Taef2RoundTripOfARealViewIsTheDirectPathsOnEveryWidth) {
  // The whole network through every path: the round trip of a fern view with the float32 Winograd kernels
  // of each width against oneDNN's direct convolutions, within 0.01 dB (the budget is 0.05; float32
  // rounding of the order of 1e-6 moves the PSNR by far less).
  const auto isas = levels();
  if (isas.empty()) GTEST_SKIP() << "this CPU has no AVX2 with FMA";
  torch::NoGradGuard no_grad;
  const at::Tensor x = lrf::image_to_batch(lrf::center_crop_to_multiple(
      lrf::read_image_rgb(lrf_test::shared_dir() + "/scenes/llff-fern/images_8/image000.png"), 8));
  auto psnr_with = [&](const char* isa, const char* winograd) {
    lrf::test::ScopedEnv cap("LRF_CPU_ISA", isa), on("LRF_WINOGRAD", winograd);
    auto ae = lrf::load_autoencoder(lrf_test::shared_dir() + "/models/taef2");  // built under this path
    ae->set_precision(lrf::Precision::fp32);
    return lrf::psnr(ae->decode(ae->encode(x))[0], x[0]);
  };
  const double direct = psnr_with(isas.back().c_str(), "0");
  for (const auto& isa : isas) {
    const double winograd = psnr_with(isa.c_str(), "1");
    std::printf("TAEF2 round trip, fern view 0: %s Winograd %.4f dB, direct %.4f dB\n", isa.c_str(), winograd, direct);
    EXPECT_NEAR(winograd, direct, 0.01) << isa;
  }
}
