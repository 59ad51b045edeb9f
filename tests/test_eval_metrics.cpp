#include <cmath>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <torch/torch.h>

#include "lrf/core/error.h"
#include "lrf/eval/metrics.h"

namespace {

// SSIM straight from its definition, in float64 with plain loops: the 11×11 Gaussian window (σ = 1.5)
// weights each pixel's neighbourhood, pixels outside the image count as zero (3DGS's same-size zero
// padding), and the map is averaged over channels and pixels.
double reference_ssim(const torch::Tensor& a, const torch::Tensor& b) {
  auto x = a.to(torch::kFloat64).clamp(0, 1).contiguous();
  auto y = b.to(torch::kFloat64).clamp(0, 1).contiguous();
  const int64_t C = x.size(0), H = x.size(1), W = x.size(2);
  const double* px = x.data_ptr<double>();
  const double* py = y.data_ptr<double>();
  double w1[11], sum = 0;
  for (int i = 0; i < 11; ++i) sum += w1[i] = std::exp(-(i - 5) * (i - 5) / (2 * 1.5 * 1.5));
  for (double& w : w1) w /= sum;
  const double c1 = 1e-4, c2 = 9e-4;
  double total = 0;
  for (int64_t c = 0; c < C; ++c) {
    for (int64_t r = 0; r < H; ++r) {
      for (int64_t q = 0; q < W; ++q) {
        double mx = 0, my = 0, sxx = 0, syy = 0, sxy = 0;
        for (int i = 0; i < 11; ++i) {
          for (int j = 0; j < 11; ++j) {
            int64_t rr = r + i - 5, qq = q + j - 5;
            if (rr < 0 || rr >= H || qq < 0 || qq >= W) continue;
            double w = w1[i] * w1[j];
            double u = px[(c * H + rr) * W + qq], v = py[(c * H + rr) * W + qq];
            mx += w * u;
            my += w * v;
            sxx += w * u * u;
            syy += w * v * v;
            sxy += w * u * v;
          }
        }
        double vx = sxx - mx * mx, vy = syy - my * my, cxy = sxy - mx * my;
        total += ((2 * mx * my + c1) * (2 * cxy + c2)) / ((mx * mx + my * my + c1) * (vx + vy + c2));
      }
    }
  }
  return total / static_cast<double>(C * H * W);
}

torch::Tensor random_image(int64_t c, int64_t h, int64_t w, uint64_t seed) {
  auto gen = at::detail::createCPUGenerator(seed);
  return torch::rand({c, h, w}, gen, torch::kFloat32);
}

}  // namespace

TEST(EvalMetrics, PsnrOfConstantOffsetIsTwentyDb) {
  // MSE = 0.1² = 0.01 → PSNR = 10·log10(1 / 0.01) = 20 dB. Inputs in [0, 0.9] so clamping keeps the offset;
  // the float32 images carry ~1e-8 rounding in the offset, far below the 1e-5 dB tolerance.
  auto a = random_image(3, 16, 20, 1) * 0.9;
  auto b = a + 0.1;
  EXPECT_NEAR(lrf::psnr(a, b), 20.0, 1e-5);
  // In float64 the offset is exact to ~1e-16.
  EXPECT_NEAR(lrf::psnr(a.to(torch::kFloat64), a.to(torch::kFloat64) + 0.1), 20.0, 1e-9);
  // With a peak of 2: 10·log10(4 / 0.01) = 26.0206 dB.
  EXPECT_NEAR(lrf::psnr_unclamped(a, b, 2.0), 10.0 * std::log10(400.0), 1e-5);
}

TEST(EvalMetrics, IdenticalImagesGiveCapAndOne) {
  auto a = random_image(3, 24, 24, 2);
  EXPECT_EQ(lrf::psnr(a, a), lrf::kPsnrCapDb);
  EXPECT_TRUE(std::isfinite(lrf::psnr(a, a)));
  EXPECT_NEAR(lrf::ssim(a, a), 1.0, 1e-12);
}

TEST(EvalMetrics, InputsAreClampedToTheImageRange) {
  // Values beyond [0, 1] are clamped as 3DGS clamps renders: overshoot above 1 costs nothing.
  auto a = torch::ones({3, 8, 8});
  EXPECT_EQ(lrf::psnr(a, a * 1.5), lrf::kPsnrCapDb);
  EXPECT_NEAR(lrf::ssim(a, a * 1.5), 1.0, 1e-12);
  // ...but not in the unclamped (latent) variant: MSE 0.25 → 6.02 dB.
  EXPECT_NEAR(lrf::psnr_unclamped(a, a * 1.5, 1.0), 10.0 * std::log10(4.0), 1e-9);
}

TEST(EvalMetrics, SsimMatchesPlainLoopReference) {
  // Non-square and smaller than twice the window, so borders (zero padding) dominate; a correlated pair
  // (blended with noise) so that the value is neither 0 nor 1. The two float64 computations differ only in the
  // order of additions: 1e-10 is many orders above their rounding (~1e-14).
  auto a = random_image(3, 19, 27, 3);
  auto b = 0.6 * a + 0.4 * random_image(3, 19, 27, 4);
  double expected = reference_ssim(a, b);
  EXPECT_GT(expected, 0.2);
  EXPECT_LT(expected, 0.95);
  EXPECT_NEAR(lrf::ssim(a, b), expected, 1e-10);
  // Unrelated images: low SSIM, still the same as the reference.
  auto c = random_image(3, 19, 27, 5);
  EXPECT_NEAR(lrf::ssim(a, c), reference_ssim(a, c), 1e-10);
  // Symmetric.
  EXPECT_NEAR(lrf::ssim(a, b), lrf::ssim(b, a), 1e-12);
}

TEST(EvalMetrics, SsimOfLargerImageMatchesReference) {
  auto a = random_image(1, 40, 33, 6);
  auto b = (a * 0.7 + 0.1).clamp(0, 1);
  EXPECT_NEAR(lrf::ssim(a, b), reference_ssim(a, b), 1e-10);
}

TEST(EvalMetrics, CvMatOverloadsAgreeWithTensors) {
  cv::Mat a(12, 10, CV_32FC3), b(12, 10, CV_32FC3);
  cv::RNG rng(7);
  rng.fill(a, cv::RNG::UNIFORM, 0.0, 1.0);
  rng.fill(b, cv::RNG::UNIFORM, 0.0, 1.0);
  auto ta = lrf::image_to_chw(a);
  ASSERT_EQ(ta.sizes(), (std::vector<int64_t>{3, 12, 10}));
  EXPECT_FLOAT_EQ(ta[1][4][7].item<float>(), a.at<cv::Vec3f>(4, 7)[1]);
  EXPECT_DOUBLE_EQ(lrf::psnr(a, b), lrf::psnr(ta, lrf::image_to_chw(b)));
  EXPECT_DOUBLE_EQ(lrf::ssim(a, b), lrf::ssim(ta, lrf::image_to_chw(b)));
  // 8-bit images are scaled to [0, 1].
  cv::Mat u8(4, 4, CV_8UC3, cv::Scalar(255, 0, 51));
  auto t8 = lrf::image_to_chw(u8);
  EXPECT_FLOAT_EQ(t8[0][0][0].item<float>(), 1.0f);
  EXPECT_FLOAT_EQ(t8[2][3][3].item<float>(), 0.2f);
  // One-channel images too (the tensor must own its memory: the Mat is gone after the call).
  auto t1 = lrf::image_to_chw(cv::Mat(3, 5, CV_32FC1, cv::Scalar(0.25)));
  EXPECT_EQ(t1.sizes(), (std::vector<int64_t>{1, 3, 5}));
  EXPECT_FLOAT_EQ(t1.sum().item<float>(), 15 * 0.25f);
}

TEST(EvalMetrics, MismatchedShapesAreErrors) {
  auto a = torch::zeros({3, 8, 8});
  EXPECT_THROW(lrf::psnr(a, torch::zeros({3, 8, 7})), lrf::Error);
  EXPECT_THROW(lrf::ssim(a, torch::zeros({3, 8, 7})), lrf::Error);
  EXPECT_THROW(lrf::ssim(a.unsqueeze(0), a.unsqueeze(0)), lrf::Error);
  try {
    lrf::ssim(a, torch::zeros({3, 8, 7}));
  } catch (const lrf::Error& e) {
    EXPECT_NE(std::string(e.what()).find("[3, 8, 7]"), std::string::npos) << e.what();
  }
}
