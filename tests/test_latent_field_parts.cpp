// Stage II's pieces that do not need a network: latent normalisation and the SfM-point feature start.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include "lrf/core/error.h"
#include "lrf/latent/latent_init.h"
#include "lrf/latent/latent_normalization.h"

namespace {

TEST(LatentRange, NormalisesTrainingLatentsToUnitRangeAndBack) {
  torch::manual_seed(1);
  std::vector<torch::Tensor> train = {torch::randn({4, 5, 6}) * 3 + 1, torch::randn({4, 5, 6}) * 0.5};
  auto r = lrf::compute_latent_range(train);
  for (const auto& z : train) {
    auto n = r.normalize(z);
    EXPECT_GE(n.min().item<float>(), 0.0f);
    EXPECT_LE(n.max().item<float>(), 1.0f + 1e-6f);
    EXPECT_LT((r.denormalize(n) - z).abs().max().item<float>(), 1e-5f);
  }
  // Each channel reaches 0 and 1 somewhere over the training set.
  auto both = torch::stack({r.normalize(train[0]), r.normalize(train[1])});
  auto per_channel_min = std::get<0>(both.transpose(0, 1).reshape({4, -1}).min(1));
  auto per_channel_max = std::get<0>(both.transpose(0, 1).reshape({4, -1}).max(1));
  EXPECT_LT(per_channel_min.abs().max().item<float>(), 1e-6f);
  EXPECT_LT((per_channel_max - 1).abs().max().item<float>(), 1e-6f);
  // Test views outside the training range are clamped on the way back.
  auto outside = torch::full({4, 1, 1}, 1e3f);
  EXPECT_LT((r.denormalize(r.normalize(outside)) - torch::tensor(r.max).view({4, 1, 1})).abs().max().item<float>(), 1e-3f);
  auto j = r.to_json();
  auto back = lrf::LatentRange::from_json(j, "x.json");
  EXPECT_EQ(back.min, r.min);
  j["max"][0] = -1e9;
  EXPECT_THROW(lrf::LatentRange::from_json(j, "x.json"), lrf::Error);
  EXPECT_THROW(r.normalize(torch::zeros({3, 2, 2})), lrf::Error);
}

TEST(LatentInit, PointsTakeTheLatentAtTheirProjections) {
  lrf::Camera cam;
  cam.width = 64;
  cam.height = 48;
  cam.fx = cam.fy = 60;
  cam.cx = 32;
  cam.cy = 24;
  // Latent 8x6 whose value in channel c at (row i, col j) is c + 10 i + 100 j.
  auto ii = torch::arange(6, torch::kFloat).view({1, 6, 1});
  auto jj = torch::arange(8, torch::kFloat).view({1, 1, 8});
  auto cc = torch::arange(2, torch::kFloat).view({2, 1, 1});
  auto latent = cc + 10 * ii + 100 * jj;
  // A point projecting to image pixel (20, 12): the centre of latent sample (row 1, col 2).
  double z = 3;
  Eigen::Vector3d p((20 - 32) * z / 60, (12 - 24) * z / 60, z);
  Eigen::Vector3d behind(0, 0, -2);
  auto f = lrf::sample_latents_at_points({cam, cam}, {latent, latent + 2}, {p, behind});
  EXPECT_NEAR(f[0][0].item<float>(), 0 + 10 + 200 + 1, 1e-4);  // mean over the two views: +1
  EXPECT_NEAR(f[0][1].item<float>(), 1 + 10 + 200 + 1, 1e-4);
  EXPECT_NEAR(f[1][0].item<float>(), 0.5, 1e-6);  // unseen
  auto rgb = lrf::rgb_into_first_channels(torch::tensor({{0.1f, 0.2f, 0.3f}}), 5);
  EXPECT_NEAR(rgb[0][2].item<float>(), 0.3, 1e-6);
  EXPECT_NEAR(rgb[0][4].item<float>(), 0.5, 1e-6);
}

}  // namespace
