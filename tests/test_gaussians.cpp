#include <gtest/gtest.h>
#include <torch/torch.h>

#include "lrf/splat/gaussians.h"
#include "lrf/splat/train/mip_filter.h"

using namespace lrf::splat;

TEST(Gaussians, ThreeNearestNeighboursMatchBruteForce) {
  for (int64_t n : {2, 5, 700}) {
    auto xyz = torch::randn({n, 3}) * torch::tensor({1.0f, 3.0f, 0.2f});
    auto got = mean_sq_dist_3nn(xyz);
    auto d2 = torch::cdist(xyz.to(torch::kFloat64), xyz.to(torch::kFloat64)).pow(2);
    d2.fill_diagonal_(1e30);
    const int64_t k = std::min<int64_t>(3, n - 1);
    auto want = std::get<0>(d2.topk(k, 1, false)).mean(1);
    EXPECT_TRUE(torch::allclose(got.to(torch::kFloat64), want, 1e-4, 1e-9)) << n;
  }
  // Points on a plane (forward-facing SfM clouds are nearly flat) and duplicates.
  auto flat = torch::randn({300, 3});
  flat.select(1, 2).zero_();
  auto got = mean_sq_dist_3nn(flat);
  auto d2 = torch::cdist(flat, flat).pow(2);
  d2.fill_diagonal_(1e30);
  EXPECT_TRUE(torch::allclose(got, std::get<0>(d2.topk(3, 1, false)).mean(1), 1e-3, 1e-7));
  EXPECT_GT(mean_sq_dist_3nn(torch::zeros({4, 3})).min().item<float>(), 0.0f);
}

TEST(Gaussians, FromPointsUsesFeaturesAndInriaDefaults) {
  auto xyz = torch::rand({50, 3});
  auto features = torch::rand({50, 4});
  auto g = gaussians_from_points(xyz, features, 2);
  EXPECT_EQ(g.channels(), 4);
  EXPECT_EQ(g.sh.size(1), 9);
  EXPECT_TRUE(torch::allclose(sh_dc_to_features(g.sh_dc().squeeze(1)), features, 1e-5, 1e-6));
  EXPECT_TRUE(torch::allclose(torch::sigmoid(g.opacity_logits), torch::full({50, 1}, 0.1f)));
  EXPECT_EQ(g.sh_rest().abs().sum().item<float>(), 0.0f);
  EXPECT_TRUE(g.means.requires_grad());
}

TEST(MipFilter, FilterFromClosestCameraAndPreservesIntegratedDensity) {
  lrf::Camera near_cam, far_cam;
  near_cam.width = far_cam.width = 100;
  near_cam.height = far_cam.height = 100;
  near_cam.fx = near_cam.fy = far_cam.fx = far_cam.fy = 50;
  near_cam.cx = near_cam.cy = far_cam.cx = far_cam.cy = 50;
  near_cam.t = Eigen::Vector3d(0, 0, 2);  // point at origin is 2 in front
  far_cam.t = Eigen::Vector3d(0, 0, 10);
  auto means = torch::tensor({{0.0f, 0.0f, 0.0f}, {100.0f, 0.0f, 0.0f}});
  auto f = compute_3d_filter(means, {near_cam, far_cam});
  EXPECT_NEAR(f[0].item<float>(), std::sqrt(0.2) * 2 / 50, 1e-6);
  EXPECT_NEAR(f[1].item<float>(), f[0].item<float>(), 1e-6);  // unseen: the largest value found
  auto ls = torch::log(torch::tensor({{0.01f, 0.02f, 0.03f}, {1.0f, 1.0f, 1.0f}}));
  auto logits = torch::zeros({2, 1});
  auto out = apply_3d_filter(ls, logits, f);
  // opacity * sqrt(det S^2) is unchanged by the filter (same peak-integrated mass).
  auto mass_before = torch::sigmoid(logits).squeeze(1) * ls.sum(1).exp();
  auto mass_after = torch::sigmoid(out.opacity_logits).squeeze(1) * out.log_scales.sum(1).exp();
  EXPECT_TRUE(torch::allclose(mass_before, mass_after, 1e-4));
  EXPECT_GT(out.log_scales[0][0].item<float>(), ls[0][0].item<float>());
}
