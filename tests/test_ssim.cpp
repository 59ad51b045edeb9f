// SSIM / loss against a float64 plain-loop reference of the 3DGS formula.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "lrf/splat/train/loss.h"
#include "lrf/splat/train/ssim_fused.h"

namespace {

// Direct 11x11 window, zero padding, per channel, in double.
double reference_ssim(const torch::Tensor& a_in, const torch::Tensor& b_in) {
  auto a = a_in.to(torch::kFloat64).contiguous();
  auto b = b_in.to(torch::kFloat64).contiguous();
  const int C = a.size(0), H = a.size(1), W = a.size(2);
  double w1[11], sum = 0;
  for (int i = 0; i < 11; ++i) sum += (w1[i] = std::exp(-double((i - 5) * (i - 5)) / (2 * 1.5 * 1.5)));
  for (double& w : w1) w /= sum;
  auto pa = a.accessor<double, 3>(), pb = b.accessor<double, 3>();
  const double c1 = 1e-4, c2 = 9e-4;
  double total = 0;
  for (int c = 0; c < C; ++c)
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        double ma = 0, mb = 0, saa = 0, sbb = 0, sab = 0;
        for (int dy = -5; dy <= 5; ++dy)
          for (int dx = -5; dx <= 5; ++dx) {
            int yy = y + dy, xx = x + dx;
            if (yy < 0 || yy >= H || xx < 0 || xx >= W) continue;
            double w = w1[dy + 5] * w1[dx + 5];
            double va = pa[c][yy][xx], vb = pb[c][yy][xx];
            ma += w * va;
            mb += w * vb;
            saa += w * va * va;
            sbb += w * vb * vb;
            sab += w * va * vb;
          }
        double va = saa - ma * ma, vb = sbb - mb * mb, cov = sab - ma * mb;
        total += ((2 * ma * mb + c1) * (2 * cov + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
      }
  return total / (double(C) * H * W);
}

}  // namespace

TEST(Ssim, MatchesPlainLoopReferenceForSeveralChannelCounts) {
  torch::manual_seed(3);
  for (int c : {1, 3, 4, 32}) {
    auto a = torch::rand({c, 23, 17});
    auto b = (a + 0.2 * torch::randn({c, 23, 17})).clamp(0, 1);
    const double got = lrf::splat::ssim(a, b).item<double>();
    const double want = reference_ssim(a, b);
    // float32 sums of ~121 terms: agreement to 1e-5 absolute.
    EXPECT_NEAR(got, want, 1e-5) << "C=" << c;
    EXPECT_LT(want, 0.95);  // the images differ: not a trivially perfect score
  }
}

TEST(Ssim, IdenticalImagesScoreOneAndLossIsZero) {
  auto a = torch::rand({3, 16, 16});
  EXPECT_NEAR(lrf::splat::ssim(a, a).item<double>(), 1.0, 1e-6);
  EXPECT_NEAR(lrf::splat::photometric_loss(a, a).item<double>(), 0.0, 1e-6);
}

TEST(Ssim, GradientMatchesFiniteDifferences) {
  torch::manual_seed(5);
  auto a = torch::rand({2, 9, 8}, torch::kFloat64).set_requires_grad(true);
  auto b = torch::rand({2, 9, 8}, torch::kFloat64);
  auto loss = lrf::splat::photometric_loss(a, b);
  loss.backward();
  auto g = a.grad();
  const double h = 1e-6;
  for (int idx : {0, 17, 70, 143}) {
    auto ap = a.detach().clone(), am = a.detach().clone();
    ap.view(-1)[idx] += h;
    am.view(-1)[idx] -= h;
    double fd = (lrf::splat::photometric_loss(ap, b).item<double>() -
                 lrf::splat::photometric_loss(am, b).item<double>()) / (2 * h);
    EXPECT_NEAR(g.view(-1)[idx].item<double>(), fd, 1e-6);
  }
}

TEST(Psnr, KnownValue) {
  auto a = torch::zeros({3, 4, 4});
  auto b = torch::full({3, 4, 4}, 0.1);
  EXPECT_NEAR(lrf::splat::psnr(a, b), 20.0, 1e-4);
  // Values outside [0, 1] are clamped first.
  EXPECT_NEAR(lrf::splat::psnr(a - 5, b), 20.0, 1e-4);
}

TEST(Ssim, FusedKernelMatchesReferenceValueAndGradient) {
  torch::manual_seed(9);
  for (int c : {1, 3, 32}) {
    auto a = torch::rand({c, 19, 23});
    auto b = (a + 0.3 * torch::randn({c, 19, 23})).clamp(0, 1);
    EXPECT_NEAR(lrf::splat::fused_ssim(a, b).item<double>(), reference_ssim(a, b), 2e-5) << c;
    // Gradient against the ATen formula (autograd) in float64.
    auto a64 = a.to(torch::kFloat64).set_requires_grad(true);
    lrf::splat::ssim(a64, b.to(torch::kFloat64)).backward();
    auto a32 = a.clone().set_requires_grad(true);
    lrf::splat::fused_ssim(a32, b).backward();
    const double scale = a64.grad().abs().max().item<double>();
    EXPECT_LT((a32.grad().to(torch::kFloat64) - a64.grad()).abs().max().item<double>(), 1e-4 * scale) << c;
  }
}
