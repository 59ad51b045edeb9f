// Densification on a hand-made field: the right Gaussians are cloned, split and pruned, and the Adam
// moments stay attached to the rows they belong to.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include "lrf/splat/train/densify.h"
#include "lrf/splat/train/optimizer.h"

using namespace lrf::splat;

namespace {

struct Fixture {
  Gaussians g;
  GaussianAdam adam;
  Densifier d;
};

// Rows: 0 small+hot (clone), 1 big+hot (split), 2 cold, 3 transparent (prune), 4 small+hot, 5 cold.
Fixture make_fixture() {
  Fixture f;
  const int64_t n = 6;
  f.g.max_sh_degree = 1;
  f.g.means = torch::arange(n * 3, torch::kFloat32).view({n, 3});
  f.g.log_scales = torch::tensor({0.001f, 0.05f, 0.001f, 0.001f, 0.002f, 0.001f}).log().unsqueeze(1).repeat({1, 3});
  f.g.log_scales[1][2] = std::log(0.02f);
  f.g.quats = torch::tensor({1.0f, 0.0f, 0.0f, 0.0f}).repeat({n, 1});
  auto opacity = torch::tensor({0.5f, 0.5f, 0.5f, 0.001f, 0.5f, 0.5f}).unsqueeze(1);
  f.g.opacity_logits = (opacity / (1 - opacity)).log();
  f.g.sh = torch::arange(n * 4 * 3, torch::kFloat32).view({n, 4, 3});
  f.g.make_leaves();
  f.adam = GaussianAdam(f.g, LearningRates{}, 1.0, 100);
  // Marker moments: every value of row i is i + 1 (m) and 10 (i + 1) (v).
  std::vector<torch::Tensor> state;
  for (int pass = 0; pass < 2; ++pass)
    for (auto* p : f.g.parameters()) {
      auto shape = p->sizes().vec();
      auto rows = torch::arange(1, n + 1, torch::kFloat32) * (pass ? 10.0f : 1.0f);
      for (size_t k = 1; k < shape.size(); ++k) rows = rows.unsqueeze(-1);
      state.push_back(rows.expand(shape).contiguous());
    }
  f.adam.set_state(state, 7);
  f.d.resize(n);
  // Two views' worth of statistics: rows 0, 1, 4 have a mean gradient of 3e-4 > 2e-4.
  auto grad = torch::zeros({n, 2});
  for (int r : {0, 1, 4}) grad[r][0] = 3e-4f;
  grad[2][0] = 1e-4f;
  auto radii = torch::full({n}, 5, torch::kInt32);
  f.d.accumulate(grad, radii);
  f.d.accumulate(grad, radii);
  return f;
}

}  // namespace

TEST(Densify, CloneSplitPruneKeepAdamStateAligned) {
  auto f = make_fixture();
  auto original = f.g.clone();
  DensifyOptions o;
  auto stats = f.d.densify_and_prune(f.g, f.adam, 1.0, false, 42, o);
  EXPECT_EQ(stats.cloned, 2);
  EXPECT_EQ(stats.split, 1);
  EXPECT_EQ(stats.pruned, 1);
  ASSERT_EQ(f.g.size(), 8);
  EXPECT_EQ(stats.after, 8);
  // Kept originals first, in order, with their own moments.
  const int kept[] = {0, 2, 4, 5};
  auto state = f.adam.state();
  for (int i = 0; i < 4; ++i) {
    EXPECT_TRUE(torch::equal(f.g.means[i], original.means[kept[i]])) << i;
    EXPECT_TRUE(torch::equal(f.g.sh[i], original.sh[kept[i]])) << i;
    for (int k = 0; k < GaussianAdam::kGroups; ++k) {
      EXPECT_TRUE((state[k][i] == float(kept[i] + 1)).all().item<bool>()) << "m group " << k << " row " << i;
      EXPECT_TRUE((state[5 + k][i] == float(10 * (kept[i] + 1))).all().item<bool>());
    }
  }
  // New rows (clones of 0 and 4, two children of 1) start with zero moments.
  for (int i = 4; i < 8; ++i)
    for (auto& t : state) EXPECT_TRUE((t[i] == 0).all().item<bool>()) << "row " << i;
  EXPECT_TRUE(torch::equal(f.g.means[4], original.means[0]));
  EXPECT_TRUE(torch::equal(f.g.log_scales[5], original.log_scales[4]));
  for (int i = 6; i < 8; ++i) {
    EXPECT_TRUE(torch::allclose(f.g.log_scales[i], original.log_scales[1] - std::log(1.6)));
    EXPECT_TRUE(torch::equal(f.g.sh[i], original.sh[1]));
    auto offset = (f.g.means[i] - original.means[1]).abs();
    EXPECT_GT(offset.sum().item<float>(), 0.0f);
    EXPECT_LT(offset.max().item<float>(), 5 * 0.05f);  // within 5 sigma of the parent
  }
  // Statistics restart, sized to the new field; parameters are leaves again.
  EXPECT_EQ(f.d.grad_accum.numel(), 8);
  EXPECT_EQ(f.d.grad_accum.sum().item<float>(), 0.0f);
  EXPECT_TRUE(f.g.means.requires_grad() && f.g.means.is_leaf());
}

TEST(Densify, CapKeepsTheLargestGradients) {
  auto f = make_fixture();
  f.d.grad_accum[4] = 1.0f;  // row 4 is the hottest
  DensifyOptions o;
  o.max_gaussians = 7;  // room for one more
  auto stats = f.d.densify_and_prune(f.g, f.adam, 1.0, false, 1, o);
  EXPECT_EQ(stats.cloned + stats.split, 1);
  EXPECT_EQ(stats.cloned, 1);
  EXPECT_LE(f.g.size(), 7);
}

TEST(Densify, ScreenAndWorldSizePruningOnlyWhenAsked) {
  auto f = make_fixture();
  f.d.max_radii[2] = 50.0f;  // huge on screen
  DensifyOptions o;
  o.grad_threshold = 1.0;  // nothing grows
  auto stats = f.d.densify_and_prune(f.g, f.adam, 1.0, false, 1, o);
  EXPECT_EQ(stats.pruned, 1);  // only the transparent one
  auto f3 = make_fixture();
  f3.d.max_radii[2] = 50.0f;
  stats = f3.d.densify_and_prune(f3.g, f3.adam, 1.0, true, 1, o);
  EXPECT_EQ(stats.pruned, 2);
}

TEST(Densify, OpacityResetCapsOpacityAndClearsItsMoments) {
  auto f = make_fixture();
  Densifier::reset_opacity(f.g, f.adam);
  auto o = torch::sigmoid(f.g.opacity_logits);
  EXPECT_LE(o.max().item<float>(), 0.0100001f);
  EXPECT_NEAR(o[3].item<float>(), 0.001f, 1e-6);
  auto state = f.adam.state();
  EXPECT_EQ(state[3].abs().sum().item<float>(), 0.0f);
  EXPECT_EQ(state[8].abs().sum().item<float>(), 0.0f);
  EXPECT_GT(state[0].abs().sum().item<float>(), 0.0f);
}

TEST(DensifySchedule, InriaAt30kAndCompressedBelow) {
  auto s = DensifySchedule::for_iterations(30000);
  EXPECT_EQ(s.from, 500);
  EXPECT_EQ(s.until, 15000);
  EXPECT_EQ(s.interval, 100);
  EXPECT_EQ(s.opacity_reset_every, 3000);
  auto t = DensifySchedule::for_iterations(7000);
  EXPECT_EQ(t.until, 3500);
  EXPECT_EQ(t.opacity_reset_every, 3000);
  EXPECT_EQ(t.interval, 100);
  EXPECT_EQ(t.from, 500);
  auto u = DensifySchedule::for_iterations(700);
  EXPECT_EQ(u.until, 350);
  EXPECT_EQ(u.from, 50);
  EXPECT_EQ(u.interval, 10);
  EXPECT_EQ(u.sh_degree_every, 100);
  EXPECT_FALSE(s.densify_at(500));
  EXPECT_TRUE(s.densify_at(600));
  EXPECT_FALSE(s.densify_at(15000));
  EXPECT_GE(DensifySchedule::for_iterations(300).interval, 10);
}

TEST(Densify, SortSpatiallyFollowsTheZCurveAndKeepsMomentsAligned) {
  auto f = make_fixture();
  // The 8 corners of a cube, listed so that Z-order (x the lowest bit, then y, then z) is 5 7 2 0 6 1 4 3
  // (codes x + 2y + 4z: 3 5 2 7 6 0 4 1).
  const float corners[8][3] = {{1, 1, 0}, {1, 0, 1}, {0, 1, 0}, {1, 1, 1}, {0, 1, 1}, {0, 0, 0}, {0, 0, 1}, {1, 0, 0}};
  {
    torch::NoGradGuard ng;
    f.g.means = torch::from_blob(const_cast<float*>(&corners[0][0]), {8, 3}, torch::kFloat32).clone();
    for (auto* p : f.g.parameters())
      if (p != &f.g.means) *p = torch::cat({*p, p->narrow(0, 0, 2)});  // 8 rows: rows 6, 7 repeat 0, 1
  }
  f.g.make_leaves();
  std::vector<torch::Tensor> state;
  for (int pass = 0; pass < 2; ++pass)
    for (auto* p : f.g.parameters()) {
      auto rows = torch::arange(1, 9, torch::kFloat32) * (pass ? 10.0f : 1.0f);
      for (int64_t k = 1; k < p->dim(); ++k) rows = rows.unsqueeze(-1);
      state.push_back(rows.expand(p->sizes()).contiguous());
    }
  f.adam.set_state(state, 3);
  auto original = f.g.clone();
  sort_spatially(f.g, f.adam);
  const int64_t expected[8] = {5, 7, 2, 0, 6, 1, 4, 3};
  auto moments = f.adam.state();
  for (int i = 0; i < 8; ++i) {
    const int64_t from = expected[i];
    EXPECT_TRUE(torch::equal(f.g.means[i], original.means[from])) << i;
    EXPECT_TRUE(torch::equal(f.g.sh[i], original.sh[from])) << i;
    EXPECT_TRUE(torch::equal(f.g.quats[i], original.quats[from])) << i;
    for (int k = 0; k < GaussianAdam::kGroups; ++k) {
      EXPECT_TRUE((moments[k][i] == float(from + 1)).all().item<bool>()) << "m group " << k << " row " << i;
      EXPECT_TRUE((moments[5 + k][i] == float(10 * (from + 1))).all().item<bool>()) << "v group " << k;
    }
  }
  EXPECT_TRUE(f.g.means.requires_grad() && f.g.means.is_leaf());
  EXPECT_EQ(f.adam.steps_taken(), 3);
}

TEST(Densify, StatisticsCountOnlyVisibleRows) {
  Densifier d(3);
  auto grad = torch::tensor({{3.f, 4.f}, {1.f, 0.f}, {0.f, 2.f}});
  d.accumulate(grad, torch::tensor({2, 0, 7}, torch::kInt32));
  d.accumulate(grad * 2, torch::tensor({5, 0, 3}, torch::kInt32));
  // Row 0: |(3, 4)| + |(6, 8)| over two views, largest radius 5; row 1 was never visible.
  EXPECT_FLOAT_EQ(d.grad_accum[0].item<float>(), 15.f);
  EXPECT_FLOAT_EQ(d.denom[0].item<float>(), 2.f);
  EXPECT_FLOAT_EQ(d.max_radii[0].item<float>(), 5.f);
  EXPECT_FLOAT_EQ(d.grad_accum[1].item<float>(), 0.f);
  EXPECT_FLOAT_EQ(d.denom[1].item<float>(), 0.f);
  EXPECT_FLOAT_EQ(d.max_radii[1].item<float>(), 0.f);
  EXPECT_FLOAT_EQ(d.grad_accum[2].item<float>(), 6.f);
  EXPECT_FLOAT_EQ(d.max_radii[2].item<float>(), 7.f);
}
