// The fused Adam against torch::optim::Adam, and its exact savings.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include "lrf/core/error.h"
#include "lrf/splat/train/optimizer.h"

using namespace lrf::splat;

namespace {

Gaussians field(int64_t n, int c, int degree) {
  torch::manual_seed(11);
  Gaussians g;
  g.max_sh_degree = degree;
  g.means = torch::randn({n, 3});
  g.log_scales = torch::randn({n, 3});
  g.quats = torch::randn({n, 4});
  g.opacity_logits = torch::randn({n, 1});
  g.sh = torch::randn({n, sh_coefficients(degree), c});
  g.make_leaves();
  return g;
}

}  // namespace

TEST(GaussianAdam, MatchesTorchAdamWithInriaRates) {
  const int64_t n = 300, steps = 5;
  auto g = field(n, 4, 1);
  // The same parameters split the way torch's Adam needs them (SH DC and rest as separate tensors).
  std::vector<torch::Tensor> ref;
  for (auto* p : g.parameters()) ref.push_back(p->detach().clone());
  auto ref_dc = ref[4].narrow(1, 0, 1).clone().set_requires_grad(true);
  auto ref_rest = ref[4].narrow(1, 1, 3).clone().set_requires_grad(true);
  for (int i = 0; i < 4; ++i) ref[i].set_requires_grad(true);
  LearningRates lr;
  const double extent = 2.5;
  GaussianAdam adam(g, lr, extent, steps);
  using torch::optim::AdamOptions;
  std::vector<torch::optim::OptimizerParamGroup> groups;
  const double rates[] = {0, lr.scales, lr.rotations, lr.opacity};
  for (int i = 0; i < 4; ++i)
    groups.emplace_back(std::vector<torch::Tensor>{ref[i]}, std::make_unique<AdamOptions>(AdamOptions(rates[i]).eps(1e-15)));
  groups.emplace_back(std::vector<torch::Tensor>{ref_dc}, std::make_unique<AdamOptions>(AdamOptions(lr.sh_dc).eps(1e-15)));
  groups.emplace_back(std::vector<torch::Tensor>{ref_rest}, std::make_unique<AdamOptions>(AdamOptions(lr.sh_rest).eps(1e-15)));
  torch::optim::Adam torch_adam(groups, AdamOptions(1e-3));
  for (int s = 0; s < steps; ++s) {
    auto grads = std::vector<torch::Tensor>{torch::randn({n, 3}), torch::randn({n, 3}), torch::randn({n, 4}),
                                            torch::randn({n, 1}), torch::randn({n, 4, 4})};
    auto params = g.parameters();
    for (int i = 0; i < 5; ++i) params[i]->mutable_grad() = grads[i].clone();
    adam.step(g, 1);
    for (int i = 0; i < 4; ++i) ref[i].mutable_grad() = grads[i].clone();
    ref_dc.mutable_grad() = grads[4].narrow(1, 0, 1).clone();
    ref_rest.mutable_grad() = grads[4].narrow(1, 1, 3).clone();
    static_cast<AdamOptions&>(torch_adam.param_groups()[0].options()).lr(adam.position_lr(s));
    torch_adam.step();
  }
  EXPECT_TRUE(torch::allclose(g.means, ref[0], 1e-5, 1e-6));
  EXPECT_TRUE(torch::allclose(g.log_scales, ref[1], 1e-5, 1e-6));
  EXPECT_TRUE(torch::allclose(g.quats, ref[2], 1e-5, 1e-6));
  EXPECT_TRUE(torch::allclose(g.opacity_logits, ref[3], 1e-5, 1e-6));
  EXPECT_TRUE(torch::allclose(g.sh_dc(), ref_dc, 1e-5, 1e-6));
  EXPECT_TRUE(torch::allclose(g.sh_rest(), ref_rest, 1e-5, 1e-6));
  // The position rate follows the log-linear schedule times the extent.
  EXPECT_NEAR(adam.position_lr(0), 1.6e-4 * extent, 1e-12);
  EXPECT_NEAR(adam.position_lr(steps), 1.6e-6 * extent, 1e-12);
}

TEST(GaussianAdam, InactiveBandsAndInvisibleRowsAreSkipped) {
  auto g = field(10, 3, 2);
  GaussianAdam adam(g, LearningRates{}, 1.0, 10);
  adam.sparse = true;
  auto before = g.clone();
  for (auto* p : g.parameters()) p->mutable_grad() = torch::ones_like(*p);
  auto visible = torch::zeros({10}, torch::kBool);
  visible[3] = true;
  adam.step(g, /*active_sh_degree=*/1, visible);
  // Row 3 moved in bands 0..3 only; the degree-2 bands and the other rows did not.
  EXPECT_FALSE(torch::equal(g.means[3], before.means[3]));
  EXPECT_FALSE(torch::equal(g.sh[3].narrow(0, 0, 4), before.sh[3].narrow(0, 0, 4)));
  EXPECT_TRUE(torch::equal(g.sh[3].narrow(0, 4, 5), before.sh[3].narrow(0, 4, 5)));
  EXPECT_TRUE(torch::equal(g.means[2], before.means[2]));
  EXPECT_TRUE(torch::equal(g.sh[7], before.sh[7]));
}

// The AVX2 loop does the scalar loop's operations in the same order: same bits, tail included (n is not a
// multiple of 8), over steps where the moments start at zero and then grow.
TEST(GaussianAdam, VectorLoopMatchesScalarLoopBitForBit) {
  const int64_t n = 1003;
  torch::manual_seed(5);
  auto p0 = torch::randn({n}), m0 = torch::zeros({n}), v0 = torch::zeros({n});
  auto p1 = p0.clone(), m1 = m0.clone(), v1 = v0.clone();
  for (int t = 1; t <= 4; ++t) {
    const auto g = torch::randn({n}) * std::pow(10.0, t - 3);  // gradients from 1e-2 to 10
    const AdamScalars s = adam_scalars(1e-2, 0.9, 0.999, 1e-15, t);
    adam_update(p0.data_ptr<float>(), g.data_ptr<float>(), m0.data_ptr<float>(), v0.data_ptr<float>(), n, s, false);
    adam_update(p1.data_ptr<float>(), g.data_ptr<float>(), m1.data_ptr<float>(), v1.data_ptr<float>(), n, s, true);
  }
  EXPECT_FALSE(torch::equal(p0, torch::zeros({n})));
  EXPECT_TRUE(torch::equal(p0, p1));
  EXPECT_TRUE(torch::equal(m0, m1));
  EXPECT_TRUE(torch::equal(v0, v1));
}

// The row-by-row SH update: rows fed to the sink give step()'s result with an SH gradient tensor, bit for
// bit (inactive bands untouched); an SH gradient that arrives anyway is an error, not a second update.
TEST(GaussianAdam, ShRowUpdateEqualsTheTensorUpdateAndRefusesAStrayGradient) {
  auto a = field(37, 5, 2), b = a.clone();
  b.make_leaves();
  GaussianAdam adam_a(a, LearningRates{}, 1.0, 10), adam_b(b, LearningRates{}, 1.0, 10);
  torch::manual_seed(2);
  for (int step = 0; step < 3; ++step) {
    std::vector<torch::Tensor> grads;
    for (auto* p : a.parameters()) grads.push_back(torch::randn_like(*p));
    for (size_t k = 0; k < grads.size(); ++k) a.parameters()[k]->mutable_grad() = grads[k].clone();
    adam_a.step(a, /*active_sh_degree=*/1);
    const ShGradientSink& sink = adam_b.sh_row_update(b, 1);
    for (int64_t row = 36; row >= 0; --row) sink.consume(sink.context, row, grads[4][row].contiguous().data_ptr<float>());
    for (size_t k = 0; k < 4; ++k) b.parameters()[k]->mutable_grad() = grads[k].clone();
    adam_b.step(b, 1);
  }
  auto pa = a.parameters(), pb = b.parameters();
  for (size_t k = 0; k < pa.size(); ++k) EXPECT_TRUE(torch::equal(*pa[k], *pb[k])) << k;
  const auto sa = adam_a.state(), sb = adam_b.state();
  for (size_t k = 0; k < sa.size(); ++k) EXPECT_TRUE(torch::equal(sa[k], sb[k])) << k;

  adam_b.sh_row_update(b, 1);
  b.sh.mutable_grad() = torch::ones_like(b.sh);
  EXPECT_THROW(adam_b.step(b, 1), lrf::Error);
  adam_b.sparse = true;
  EXPECT_THROW(adam_b.sh_row_update(b, 1), lrf::Error);
}

// A run shorter than 7000 steps scales the means' and SH rates by 7000 / steps, at most 4x; the rest keep
// Inria's values, and 7000 steps or more change nothing.
TEST(LearningRates, ShortRunsMoveMeansAndShFaster) {
  using lrf::splat::LearningRates;
  const LearningRates inria;
  EXPECT_EQ(LearningRates::short_run_factor(30000), 1.0);
  EXPECT_EQ(LearningRates::short_run_factor(7000), 1.0);
  EXPECT_DOUBLE_EQ(LearningRates::short_run_factor(3500), 2.0);
  EXPECT_DOUBLE_EQ(LearningRates::short_run_factor(2500), 2.8);
  EXPECT_EQ(LearningRates::short_run_factor(1000), LearningRates::kMaxShortRunFactor);
  EXPECT_EQ(LearningRates::short_run_factor(0), LearningRates::kMaxShortRunFactor);

  const LearningRates r = inria.for_short_run(3500);
  EXPECT_DOUBLE_EQ(r.position_init, 2 * inria.position_init);
  EXPECT_DOUBLE_EQ(r.position_final, 2 * inria.position_final);
  EXPECT_DOUBLE_EQ(r.sh_dc, 2 * inria.sh_dc);
  EXPECT_DOUBLE_EQ(r.sh_rest, 2 * inria.sh_rest);
  EXPECT_EQ(r.scales, inria.scales);
  EXPECT_EQ(r.rotations, inria.rotations);
  EXPECT_EQ(r.opacity, inria.opacity);
  EXPECT_EQ(r.others_final_factor, inria.others_final_factor);

  const LearningRates same = inria.for_short_run(7000);
  EXPECT_EQ(same.position_init, inria.position_init);
  EXPECT_EQ(same.sh_dc, inria.sh_dc);
}

// decay_start holds every rate at its start for that fraction of the run, then runs the same log-linear
// decay in the rest; 0 is the decay from the first step that Stage II's means have always had.
TEST(LearningRates, DecayStartsAtItsFractionOfTheRun) {
  using lrf::splat::LearningRates;
  LearningRates r;
  EXPECT_DOUBLE_EQ(r.decay_progress(0, 100), 0.0);
  EXPECT_DOUBLE_EQ(r.decay_progress(25, 100), 0.25);
  EXPECT_DOUBLE_EQ(r.decay_progress(100, 100), 1.0);
  r.decay_start = 0.8;
  EXPECT_EQ(r.decay_progress(50, 100), 0.0);
  EXPECT_EQ(r.decay_progress(80, 100), 0.0);
  EXPECT_NEAR(r.decay_progress(90, 100), 0.5, 1e-12);
  EXPECT_DOUBLE_EQ(r.decay_progress(100, 100), 1.0);

  r.others_final_factor = 0.1;
  r.position_final = r.position_init / 100;
  auto g = field(4, 4, 1);
  const lrf::splat::GaussianAdam adam(g, r, 2.0, 100);
  EXPECT_EQ(adam.others_factor(40), 1.0);
  EXPECT_DOUBLE_EQ(adam.position_lr(40), 2.0 * r.position_init);
  EXPECT_NEAR(adam.others_factor(90), std::sqrt(0.1), 1e-12);
  EXPECT_NEAR(adam.position_lr(90), 2.0 * r.position_init / 10, 1e-15);
}
