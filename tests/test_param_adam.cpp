// The optimizer of network weights (fine-tuning, the feature lift, the latent NeRF): the same updates as a
// float64 reference and as torch's Adam, lazy entries left alone, and a save/load that resumes exactly.
#include <cmath>
#include <vector>

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

// Adam in float64 with plain loops, one entry at a time (the reference the fused float32 pass is held to).
struct ReferenceAdam {
  std::vector<double> p, m, v;
  double lr, b1 = 0.9, b2 = 0.99, eps = 1e-8;
  bool lazy = false;
  int64_t t = 0;
  void step(const std::vector<double>& g) {
    ++t;
    const double bc1 = 1 - std::pow(b1, double(t)), bc2 = 1 - std::pow(b2, double(t));
    for (size_t i = 0; i < p.size(); ++i) {
      if (lazy && g[i] == 0) continue;
      m[i] = b1 * m[i] + (1 - b1) * g[i];
      v[i] = b2 * v[i] + (1 - b2) * g[i] * g[i];
      p[i] -= lr / bc1 * m[i] / (std::sqrt(v[i] / bc2) + eps);
    }
  }
};

std::vector<double> values(const at::Tensor& t) {
  at::Tensor d = t.detach().to(at::kDouble).contiguous().reshape({-1});
  return std::vector<double>(d.data_ptr<double>(), d.data_ptr<double>() + d.numel());
}

// Gradients with exact zeros in places (a hash-grid cell no sample touched), for 15 steps.
std::vector<at::Tensor> sparse_gradients(int64_t n, int steps) {
  std::vector<at::Tensor> out;
  for (int s = 0; s < steps; ++s) {
    at::Tensor g = torch::randn({n}) * 0.3;
    g.masked_fill_(torch::rand({n}) < 0.4, 0.0);
    out.push_back(g);
  }
  return out;
}

TEST(ParamAdam, FusedAndTensorPathsMatchAFloat64ReferenceWithAndWithoutLazyEntries) {
  torch::manual_seed(11);
  const int64_t n = 40000;  // more than one parallel chunk of the fused pass
  const at::Tensor init = torch::randn({n});
  const std::vector<at::Tensor> grads = sparse_gradients(n, 15);
  for (bool lazy : {false, true}) {
    ReferenceAdam ref{values(init), std::vector<double>(n, 0), std::vector<double>(n, 0), 0.01};
    ref.lazy = lazy;
    at::Tensor f32 = init.clone();                   // the fused float32 pass
    at::Tensor f64 = init.to(at::kDouble).clone();   // the tensor-operation path
    lrf::AdamOptions o{0.01, 0.9, 0.99, 1e-8};
    lrf::ParamAdam fused({f32}, o, {lazy}), ops({f64}, o, {lazy});
    for (const auto& g : grads) {
      ref.step(values(g));
      fused.step({g});
      ops.step({g.to(at::kDouble)});
    }
    double worst32 = 0, worst64 = 0;
    const auto a = values(f32), b = values(f64);
    for (int64_t i = 0; i < n; ++i) {
      worst32 = std::max(worst32, std::abs(a[i] - ref.p[i]));
      worst64 = std::max(worst64, std::abs(b[i] - ref.p[i]));
    }
    // Each step moves an entry by at most about lr (0.01); float32 rounding of the update and of the
    // parameter (|p| < 6, ulp 5e-7) over 15 steps stays below 1e-5. The float64 path differs from the
    // reference only in operation order.
    EXPECT_LT(worst32, 1e-5) << (lazy ? "lazy" : "dense");
    EXPECT_LT(worst64, 1e-12) << (lazy ? "lazy" : "dense");
  }
}

TEST(ParamAdam, LazyEntriesWithAZeroGradientKeepValueAndMomentum) {
  at::Tensor dense = torch::zeros({2}), lazy = torch::zeros({2});
  lrf::ParamAdam d({dense}, {0.1}), l({lazy}, {0.1}, {true});
  const at::Tensor push = torch::tensor({1.0f, 1.0f}), only_first = torch::tensor({1.0f, 0.0f});
  d.step({push});
  l.step({push});
  EXPECT_TRUE(torch::equal(dense, lazy));
  const float second_before = lazy[1].item<float>();
  d.step({only_first});
  l.step({only_first});
  EXPECT_EQ(lazy[1].item<float>(), second_before);        // no gradient: not moved by stale momentum
  EXPECT_LT(dense[1].item<float>(), second_before);       // the dense update keeps going
  EXPECT_EQ(lazy[0].item<float>(), dense[0].item<float>());
}

TEST(ParamAdam, HandGradientsEqualAutogradOnesAndBumpTheVersion) {
  torch::manual_seed(5);
  at::Tensor target = torch::randn({4, 4});
  at::Tensor a = torch::randn({4, 4}).requires_grad_(true);
  at::Tensor b = a.detach().clone();
  lrf::ParamAdam by_grad({a}, {0.05}), by_hand({b}, {0.05});
  for (int i = 0; i < 5; ++i) {
    by_grad.zero_grad();
    quadratic_loss(a, target).backward();
    const at::Tensor g = a.grad().clone();
    const int64_t version = a._version();
    by_grad.step();
    // Caches keyed by the version (the fused autoencoder's packed weights) must see the update.
    EXPECT_GT(a._version(), version);
    by_hand.step({g});
  }
  EXPECT_TRUE(torch::equal(a.detach(), b));
  EXPECT_THROW(by_hand.step({}), lrf::Error);
  EXPECT_THROW(by_hand.step({torch::zeros({3})}), lrf::Error);
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
