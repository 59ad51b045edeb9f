// Stage I's loss pieces: APE weights, latent sampling at pixels, the correspondence L1, the FFT figure.
#include <cmath>

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "lrf/align/correspondence_loss.h"

namespace {

lrf::Camera camera_at(const Eigen::Vector3d& center, double yaw) {
  lrf::Camera c;
  c.width = 64;
  c.height = 48;
  c.fx = c.fy = 50;
  c.cx = 32;
  c.cy = 24;
  Eigen::Matrix3d R_c2w = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()).toRotationMatrix();
  c.R = R_c2w.transpose();
  c.t = -c.R * center;
  return c;
}

TEST(Ape, MatchesHandComputedValues) {
  lrf::Camera a = camera_at({0, 0, 0}, 0);
  // Pure translation by (3, 4, 0): E = [I | (3,4,0)], ||E - I||_F = 5.
  EXPECT_NEAR(lrf::absolute_pose_error(a, camera_at({3, 4, 0}, 0)), 5.0, 1e-12);
  // Pure rotation by 90 degrees about y: R - I has two diagonal entries cos - 1 = -1 and two
  // off-diagonal entries +-sin = +-1, so ||R - I||_F = sqrt(4) = 2.
  EXPECT_NEAR(lrf::absolute_pose_error(a, camera_at({0, 0, 0}, M_PI / 2)), 2.0, 1e-12);
  EXPECT_NEAR(lrf::absolute_pose_error(a, a), 0.0, 1e-12);
  auto w = lrf::ape_weights({5.0, 2.0, 3.0});
  EXPECT_NEAR(w[0], 0.5, 1e-12);
  EXPECT_NEAR(w[1], 0.2, 1e-12);
  EXPECT_NEAR(w[2], 0.3, 1e-12);
  auto u = lrf::ape_weights({0.0, 0.0});
  EXPECT_NEAR(u[0], 0.5, 1e-12);
}

TEST(LatentSampling, PixelCentresMapToLatentSamples) {
  // Latent sample (row 1, col 2) covers image pixels [16, 24) x [8, 16); its centre is (20, 12).
  auto z = torch::arange(2 * 3 * 4, torch::kFloat).view({2, 3, 4});
  auto px = torch::tensor({{20.0f, 12.0f}, {24.0f, 12.0f}}, torch::kFloat);
  auto s = lrf::sample_latent_at_pixels(z, px, 8);
  EXPECT_FLOAT_EQ(s[0][0].item<float>(), z[0][1][2].item<float>());
  EXPECT_FLOAT_EQ(s[0][1].item<float>(), z[1][1][2].item<float>());
  // Halfway between columns 2 and 3.
  EXPECT_FLOAT_EQ(s[1][0].item<float>(), 0.5f * (z[0][1][2].item<float>() + z[0][1][3].item<float>()));
}

TEST(CorrespondenceLoss, ZeroForIdenticalLatentsAndGradientReachesOnlyTheLatents) {
  torch::manual_seed(0);
  auto z = torch::randn({4, 6, 8}, torch::requires_grad());
  auto pts = torch::rand({10, 2}) * torch::tensor({64.0f, 48.0f});
  auto same = lrf::correspondence_l1(z, z, pts, pts);
  EXPECT_EQ(same.item<float>(), 0.0f);
  auto other = torch::randn({4, 6, 8}, torch::requires_grad());
  auto loss = lrf::correspondence_l1(z, other, pts, pts + 3.0f);
  EXPECT_GT(loss.item<float>(), 0.0f);
  loss.backward();
  EXPECT_GT(z.grad().abs().sum().item<float>(), 0.0f);
  EXPECT_GT(other.grad().abs().sum().item<float>(), 0.0f);
}

TEST(Spectrum, HighFrequencyShareSeparatesSmoothFromNoisy) {
  torch::manual_seed(0);
  auto yy = torch::arange(32, torch::kDouble).view({32, 1}).expand({32, 32});
  auto smooth = torch::sin(yy * (2 * M_PI / 32)).unsqueeze(0);  // 1/32 cycles per sample
  EXPECT_LT(lrf::high_frequency_energy_share(smooth), 1e-10);
  auto checker = torch::cos(yy * M_PI).unsqueeze(0);  // Nyquist
  EXPECT_GT(lrf::high_frequency_energy_share(checker), 1 - 1e-10);
  // White noise spreads its energy evenly over the 64x64 frequencies; 33 of 64 per axis have
  // |k| <= 16 (|f| <= 1/4), so the high share is 1 - (33/64)^2. 8 x 4096 samples of chi-square energy
  // give a relative spread well under 1%; 0.02 is generous.
  auto noise = torch::randn({8, 64, 64}, torch::kDouble);
  EXPECT_NEAR(lrf::high_frequency_energy_share(noise), 1 - (33.0 / 64) * (33.0 / 64), 0.02);
}

}  // namespace
