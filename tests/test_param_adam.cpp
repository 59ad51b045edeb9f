// The fine-tuning optimizer: same updates as torch's Adam, and a save/load that resumes exactly.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include "lrf/core/error.h"
#include "lrf/optim/param_adam.h"
#include "test_helpers.h"

namespace {

at::Tensor quadratic_loss(const at::Tensor& w, const at::Tensor& target) { return (w - target).pow(2).sum() + w.abs().sum(); }

TEST(ParamAdam, MatchesTorchAdam) {
  torch::manual_seed(3);
  at::Tensor target = torch::randn({5, 4});
  at::Tensor a = torch::randn({5, 4}).requires_grad_(true);
  at::Tensor b = a.detach().clone().requires_grad_(true);
  lrf::ParamAdam ours({a}, {0.05});
  torch::optim::Adam theirs({b}, torch::optim::AdamOptions(0.05));
  for (int i = 0; i < 20; ++i) {
    ours.zero_grad();
    quadratic_loss(a, target).backward();
    ours.step();
    theirs.zero_grad();
    quadratic_loss(b, target).backward();
    theirs.step();
  }
  EXPECT_EQ(ours.steps(), 20);
  // float32 arithmetic in a different order: agreement to a few ulps of the step size.
  EXPECT_LT((a - b).abs().max().item<double>(), 1e-5);
  EXPECT_GT((a - target).abs().max().item<double>(), 0.0);
}

TEST(ParamAdam, SaveAndLoadResumesExactly) {
  lrf::test::TempDir dir("adam");
  torch::manual_seed(4);
  at::Tensor target = torch::randn({3, 3});
  at::Tensor init = torch::randn({3, 3});
  auto run = [&](int steps, at::Tensor w, lrf::ParamAdam& opt) {
    for (int i = 0; i < steps; ++i) {
      opt.zero_grad();
      quadratic_loss(w, target).backward();
      opt.step();
    }
  };
  at::Tensor straight = init.clone().requires_grad_(true);
  lrf::ParamAdam s({straight}, {0.02});
  run(10, straight, s);

  at::Tensor first = init.clone().requires_grad_(true);
  lrf::ParamAdam f({first}, {0.02});
  run(4, first, f);
  const std::string ckpt = dir.str() + "/ckpt.safetensors";
  f.save(ckpt, {{"note", "x"}});
  at::Tensor resumed = torch::zeros({3, 3}).requires_grad_(true);
  lrf::ParamAdam r({resumed}, {0.02});
  auto meta = r.load(ckpt);
  EXPECT_EQ(meta.at("note"), "x");
  EXPECT_EQ(r.steps(), 4);
  run(6, resumed, r);
  EXPECT_TRUE(torch::equal(resumed, straight));

  at::Tensor other = torch::zeros({2, 3}).requires_grad_(true);
  lrf::ParamAdam wrong({other}, {0.02});
  EXPECT_THROW(wrong.load(ckpt), lrf::Error);
}

}  // namespace
