// The latent NeRF's kernels against the plain float64 reference (nerf_reference.h): the hash encoding,
// volume rendering, the MLPs and the whole ray renderer, values and gradients (central finite differences
// of the reference).
//
// Tolerances, and why:
// - Values: the kernels run in float32 (relative rounding ~6e-8 per operation). An encoding sums 8 products
//   per feature, an MLP layer a few dozen, a ray a dozen samples, so results of size ~1 agree to ~1e-6;
//   2e-5 leaves room for exp() and the sigmoid in float, while a wrong rule (an off-by-one cell, a swapped
//   corner weight, T as a product over the wrong samples, a missing background term) moves them by > 1e-3.
// - Gradients: central differences of the float64 reference with h = 1e-6 have truncation error ~h²·f'''
//   (~1e-12 here: smooth functions of inputs of size ~1) and rounding error ~1e-16/h ~ 1e-10. The float32
//   backward sums many contributions, some cancelling, so its error is relative to a tensor's gradient
//   scale: an entry passes when |g − fd| <= 1e-3·max|fd over its tensor| + 1e-2·|fd|. ReLU kinks are the
//   only non-smooth points; random inputs land within h of one with probability ~1e-5 per entry.
// - Observed: every entry agrees to < 1e-5 of its tensor's scale; a dropped sigmoid derivative, the
//   background left out of ∂σ, or gradients landing in the wrong table row all fail by orders of magnitude.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <ATen/ATen.h>
#include <ATen/CPUGeneratorImpl.h>
#include <ATen/Parallel.h>
#include <Eigen/Geometry>

#include "lrf/nerf/hash_encoding.h"
#include "lrf/nerf/mlp.h"
#include "lrf/nerf/nerf_reference.h"
#include "lrf/nerf/nerf_render.h"
#include "lrf/nerf/ray_sampling.h"
#include "lrf/nerf/volume_rendering.h"

namespace {

using namespace lrf::nerf;

// The gradient tolerance described above, for one tensor's entries.
void expect_gradients_close(const std::vector<double>& analytic, const std::vector<double>& numeric,
                            const std::string& what) {
  ASSERT_EQ(analytic.size(), numeric.size());
  double scale = 0;
  for (double v : numeric) scale = std::max(scale, std::fabs(v));
  ASSERT_GT(scale, 0.0) << what << ": no gradient at all, the test would prove nothing";
  int bad = 0;
  for (size_t k = 0; k < numeric.size(); ++k) {
    const double tol = 1e-3 * scale + 1e-2 * std::fabs(numeric[k]);
    if (std::fabs(analytic[k] - numeric[k]) > tol && ++bad <= 5)
      ADD_FAILURE() << what << "[" << k << "]: analytic " << analytic[k] << ", finite differences " << numeric[k];
  }
  EXPECT_EQ(bad, 0) << what;
}

// Coarse levels dense, finer ones hashed into a small table (so collisions happen).
HashGridSpec tiny_grid() {
  HashGridSpec g;
  g.levels = 4;
  g.features = 2;
  g.log2_table = 6;
  g.base_resolution = 2;
  g.max_resolution = 16;
  return g;
}

std::vector<float> random_points(int n, uint64_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<float> p(static_cast<size_t>(3 * n));
  for (auto& v : p) v = u(rng);
  // The cube's faces and corners: the last cell's clamp, exactly on a vertex.
  p[0] = 0.0f, p[1] = 1.0f, p[2] = 0.5f, p[3] = 1.0f, p[4] = 1.0f, p[5] = 1.0f;
  return p;
}

NerfField tiny_field(uint64_t seed) {
  NerfSpec spec;
  spec.grid = tiny_grid();
  spec.grid.log2_table = 8;
  spec.hidden = 8;
  spec.geo_features = 3;
  spec.channels = 4;
  spec.coarse_samples = 6;
  spec.fine_samples = 5;
  spec.bounds.near = 1.0;
  spec.bounds.far = 6.0;
  spec.bounds.center = Eigen::Vector3d(0.1, -0.1, 3.0);
  spec.bounds.half = Eigen::Vector3d(1.0, 0.8, 1.5);
  spec.bounds.unit = 1.2;
  spec.background = {0.2f, 0.0f, 0.7f, 1.0f};
  NerfField f = NerfField::create(spec, seed);
  // Grid features of a trained field's size (the ±1e-4 start would hide most of the MLPs' behaviour).
  auto gen = at::make_generator<at::CPUGeneratorImpl>(seed + 7);
  f.table.uniform_(-1.0, 1.0, gen);
  return f;
}

// Rays from a camera at the origin looking down +z, fanning out so that some leave the box.
void tiny_rays(int n, std::vector<double>* o, std::vector<double>* d) {
  o->assign(static_cast<size_t>(3 * n), 0.0);
  d->clear();
  for (int r = 0; r < n; ++r) {
    const double a = -0.6 + 1.2 * r / std::max(1, n - 1);
    d->insert(d->end(), {a, 0.3 * std::sin(3.0 * r), 1.0});
  }
}

TEST(NerfHashEncoding, LevelsGrowGeometricallyAndSmallLevelsAreDense) {
  const HashGridSpec g = tiny_grid();
  EXPECT_EQ(g.resolution(0), 2);
  EXPECT_EQ(g.resolution(3), 16);
  EXPECT_TRUE(g.level_is_dense(0));      // 3³ = 27 <= 64
  EXPECT_FALSE(g.level_is_dense(3));     // 17³ > 64
  EXPECT_EQ(g.level_entries(0), 27);
  EXPECT_EQ(g.level_entries(3), 64);
  EXPECT_EQ(g.level_offset(1), 27);
  EXPECT_EQ(g.total_entries(), g.level_offset(4));
}

TEST(NerfHashEncoding, ForwardMatchesReferenceAndBackwardIsItsTableGradient) {
  NerfField f = tiny_field(3);
  const HashGridSpec& g = f.spec.grid;
  const int n = 40, D = g.output_dim();
  const auto points = random_points(n, 11);
  std::vector<float> out(static_cast<size_t>(n * D));
  hash_encode_forward(g, f.table.data_ptr<float>(), points.data(), n, out.data());
  ReferenceField ref = ReferenceField::from(f);
  for (int s = 0; s < n; ++s) {
    const double p[3] = {points[3 * s], points[3 * s + 1], points[3 * s + 2]};
    const auto expected = reference_encode(ref, p);
    for (int k = 0; k < D; ++k) EXPECT_NEAR(out[static_cast<size_t>(s * D + k)], expected[static_cast<size_t>(k)], 2e-5);
  }

  // L = Σ d_out · encode(points): its gradient in the table, by the kernel and by differences of the reference.
  std::mt19937 rng(5);
  std::normal_distribution<float> normal;
  std::vector<float> d_out(out.size());
  for (auto& v : d_out) v = normal(rng);
  std::vector<float> d_table(static_cast<size_t>(f.table.numel()), 0.0f);
  hash_encode_backward(g, points.data(), n, d_out.data(), d_table.data());
  auto loss = [&](const ReferenceField& r) {
    double l = 0;
    for (int s = 0; s < n; ++s) {
      const double p[3] = {points[3 * s], points[3 * s + 1], points[3 * s + 2]};
      const auto e = reference_encode(r, p);
      for (int k = 0; k < D; ++k) l += d_out[static_cast<size_t>(s * D + k)] * e[static_cast<size_t>(k)];
    }
    return l;
  };
  auto& table = ref.tensor("grid.table");
  std::vector<double> numeric, analytic;
  const double h = 1e-6;
  for (size_t k = 0; k < table.size(); ++k) {
    const double keep = table[k];
    table[k] = keep + h;
    const double up = loss(ref);
    table[k] = keep - h;
    const double down = loss(ref);
    table[k] = keep;
    numeric.push_back((up - down) / (2 * h));
    analytic.push_back(d_table[k]);
  }
  expect_gradients_close(analytic, numeric, "d table");
}

// Levels run in parallel and points in order within a level: the table gradient is the same bit for bit
// for any number of threads (what makes resumed runs exact on another thread count's machine... and
// repeatable on the same one).
TEST(NerfHashEncoding, BackwardIsTheSameForAnyThreadCount) {
  NerfField f = tiny_field(4);
  const HashGridSpec& g = f.spec.grid;
  const int n = 500, D = g.output_dim();
  const auto points = random_points(n, 12);
  std::vector<float> d_out(static_cast<size_t>(n * D));
  std::mt19937 rng(6);
  std::normal_distribution<float> normal;
  for (auto& v : d_out) v = normal(rng);
  const int threads = at::get_num_threads();
  std::vector<float> one(static_cast<size_t>(f.table.numel()), 0.0f), two = one;
  at::set_num_threads(1);
  hash_encode_backward(g, points.data(), n, d_out.data(), one.data());
  at::set_num_threads(2);
  hash_encode_backward(g, points.data(), n, d_out.data(), two.data());
  at::set_num_threads(threads);
  EXPECT_EQ(one, two);
}

TEST(NerfVolumeRendering, ForwardMatchesReferenceAndBackwardMatchesFiniteDifferences) {
  const int R = 5, S = 7, C = 3;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<float> sigma(R * S), delta(R * S), values(R * S * C), background = {0.3f, 0.9f, 0.1f};
  for (int k = 0; k < R * S; ++k) {
    sigma[k] = 4.0f * u(rng);
    delta[k] = 0.02f + 0.4f * u(rng);
  }
  for (auto& v : values) v = u(rng);
  for (int r = 0; r < R; r += 2) delta[r * S + S - 1] = kLastInterval;  // NeRF's opaque last interval
  sigma[3] = 0.0f;                                                     // empty space
  std::vector<float> out(R * C), weights(R * S), weights_only(R * S), t_end(R);
  composite_forward(sigma.data(), delta.data(), values.data(), background.data(), R, S, C, out.data(), weights.data(),
                    t_end.data());
  composite_weights(sigma.data(), delta.data(), R, S, weights_only.data());
  EXPECT_EQ(weights, weights_only);

  auto reference_ray = [&](const std::vector<double>& sg, const std::vector<double>& vals, int r) {
    std::vector<double> s(sg.begin() + r * S, sg.begin() + (r + 1) * S), dl(delta.begin() + r * S, delta.begin() + (r + 1) * S);
    std::vector<std::vector<double>> v;
    for (int i = 0; i < S; ++i) v.emplace_back(vals.begin() + (r * S + i) * C, vals.begin() + (r * S + i + 1) * C);
    return reference_composite(s, dl, v, std::vector<double>(background.begin(), background.end()));
  };
  std::vector<double> sg(sigma.begin(), sigma.end()), vals(values.begin(), values.end());
  for (int r = 0; r < R; ++r) {
    const auto e = reference_ray(sg, vals, r);
    for (int c = 0; c < C; ++c) EXPECT_NEAR(out[r * C + c], e[c], 2e-6);
  }

  std::vector<float> g(R * C);
  std::normal_distribution<float> normal;
  for (auto& v : g) v = normal(rng);
  std::vector<float> d_sigma(R * S), d_values(R * S * C);
  composite_backward(sigma.data(), delta.data(), values.data(), background.data(), g.data(), R, S, C, d_sigma.data(),
                     d_values.data());
  auto loss = [&]() {
    double l = 0;
    for (int r = 0; r < R; ++r) {
      const auto e = reference_ray(sg, vals, r);
      for (int c = 0; c < C; ++c) l += g[r * C + c] * e[c];
    }
    return l;
  };
  auto differences = [&](std::vector<double>& x) {
    std::vector<double> d;
    const double h = 1e-6;
    for (auto& v : x) {
      const double keep = v;
      v = keep + h;
      const double up = loss();
      v = keep - h;
      const double down = loss();
      v = keep;
      d.push_back((up - down) / (2 * h));
    }
    return d;
  };
  expect_gradients_close(std::vector<double>(d_sigma.begin(), d_sigma.end()), differences(sg), "d sigma");
  expect_gradients_close(std::vector<double>(d_values.begin(), d_values.end()), differences(vals), "d values");
}

TEST(NerfMlp, BackwardMatchesFiniteDifferencesOfAPlainMlp) {
  const Mlp m = Mlp::create({5, 7, 6, 4}, 9);
  const int n = 9;
  auto gen = at::make_generator<at::CPUGeneratorImpl>(10);
  const at::Tensor x = at::randn({n, 5}, gen, at::kFloat), g = at::randn({n, 4}, gen, at::kFloat);
  // The same network in float64 plain loops.
  std::vector<std::vector<double>> w, b;
  for (int k = 0; k < m.layers(); ++k) {
    const at::Tensor wk = m.weights[k].to(at::kDouble).contiguous(), bk = m.biases[k].to(at::kDouble).contiguous();
    w.emplace_back(wk.data_ptr<double>(), wk.data_ptr<double>() + wk.numel());
    b.emplace_back(bk.data_ptr<double>(), bk.data_ptr<double>() + bk.numel());
  }
  std::vector<double> xd(x.data_ptr<float>(), x.data_ptr<float>() + x.numel());
  auto forward = [&](int s) {
    std::vector<double> h(xd.begin() + s * 5, xd.begin() + (s + 1) * 5);
    for (int k = 0; k < m.layers(); ++k) {
      std::vector<double> next(b[k]);
      for (size_t o = 0; o < next.size(); ++o)
        for (size_t i = 0; i < h.size(); ++i) next[o] += w[k][o * h.size() + i] * h[i];
      if (k + 1 < m.layers())
        for (auto& v : next) v = std::max(0.0, v);
      h = next;
    }
    return h;
  };
  std::vector<at::Tensor> inputs;
  const at::Tensor y = m.forward(x, &inputs);
  for (int s = 0; s < n; ++s) {
    const auto e = forward(s);
    for (int c = 0; c < 4; ++c) EXPECT_NEAR(y[s][c].item<float>(), e[c], 2e-5);
  }
  Mlp grads = m.zeros_like();
  const at::Tensor dx = m.backward(inputs, g, &grads);
  auto loss = [&]() {
    double l = 0;
    for (int s = 0; s < n; ++s) {
      const auto e = forward(s);
      for (int c = 0; c < 4; ++c) l += g[s][c].item<float>() * e[c];
    }
    return l;
  };
  auto check = [&](std::vector<double>& x_, const at::Tensor& analytic, const std::string& what) {
    std::vector<double> numeric;
    const double h = 1e-6;
    for (auto& v : x_) {
      const double keep = v;
      v = keep + h;
      const double up = loss();
      v = keep - h;
      const double down = loss();
      v = keep;
      numeric.push_back((up - down) / (2 * h));
    }
    const at::Tensor a = analytic.to(at::kDouble).contiguous();
    expect_gradients_close(std::vector<double>(a.data_ptr<double>(), a.data_ptr<double>() + a.numel()), numeric, what);
  };
  for (int k = 0; k < m.layers(); ++k) {
    check(w[k], grads.weights[k], "weight " + std::to_string(k));
    check(b[k], grads.biases[k], "bias " + std::to_string(k));
  }
  check(xd, dx, "input");
}

// The whole ray renderer: rays → samples → contraction → grid → MLPs → volume rendering, against the
// float64 reference at the same samples, and the loss's gradient in every parameter against its differences.
TEST(NerfRenderer, RaysMatchReferenceAndLossGradientsMatchFiniteDifferences) {
  NerfField f = tiny_field(21);
  const int R = 6;
  std::vector<double> o, d;
  tiny_rays(R, &o, &d);
  const Rays rays{o.data(), d.data(), R};
  auto gen = at::make_generator<at::CPUGeneratorImpl>(22);
  const at::Tensor s = place_samples(f, rays, gen);
  ASSERT_EQ(s.size(1), f.spec.samples());
  const at::Tensor rendered = render_samples(f, rays, s);
  ReferenceField ref = ReferenceField::from(f);
  for (int r = 0; r < R; ++r) {
    const auto e = reference_render_ray(ref, o.data() + 3 * r, d.data() + 3 * r, s.data_ptr<float>() + r * s.size(1),
                                        static_cast<int>(s.size(1)));
    for (int c = 0; c < f.spec.channels; ++c) EXPECT_NEAR(rendered[r][c].item<float>(), e[c], 2e-5) << r << " " << c;
  }

  const at::Tensor targets = at::rand({R, f.spec.channels}, gen, at::kFloat);
  NerfField grads = f.zeros_like();
  const double loss = loss_and_gradients(f, rays, s, targets, &grads);
  EXPECT_NEAR(loss, reference_loss(ref, rays, s, targets), 1e-6);
  const auto analytic = grads.named_tensors();
  for (size_t t = 0; t < analytic.size(); ++t) {
    const std::string name = analytic[t].first;
    auto& values = ref.tensor(name);
    const at::Tensor a = analytic[t].second.to(at::kDouble).contiguous();
    std::vector<double> numeric, an;
    const double h = 1e-6;
    for (size_t k = 0; k < values.size(); ++k) {
      // The table: only rows the samples touch can have a gradient; check those and every 7th other one.
      if (name == "grid.table" && a.data_ptr<double>()[k] == 0.0 && k % 7) continue;
      const double keep = values[k];
      values[k] = keep + h;
      const double up = reference_loss(ref, rays, s, targets);
      values[k] = keep - h;
      const double down = reference_loss(ref, rays, s, targets);
      values[k] = keep;
      numeric.push_back((up - down) / (2 * h));
      an.push_back(a.data_ptr<double>()[k]);
    }
    expect_gradients_close(an, numeric, name);
  }
}

TEST(NerfSampling, StratifiedAndImportanceSamplesFollowTheWeights) {
  std::vector<float> s(4);
  stratified_samples(4, nullptr, s.data());
  EXPECT_EQ(s, std::vector<float>({0.125f, 0.375f, 0.625f, 0.875f}));
  const float jitter[4] = {0.0f, 0.25f, 0.5f, 0.99f};
  stratified_samples(4, jitter, s.data());
  EXPECT_FLOAT_EQ(s[1], 0.3125f);

  // All the weight in bin 3 of 8: the fine samples go there, but for the 1% spread over every bin.
  std::vector<float> w(8, 0.0f), fine(16);
  w[3] = 0.8f;
  importance_samples(w.data(), 8, 16, nullptr, fine.data());
  int inside = 0;
  for (size_t k = 0; k < fine.size(); ++k) {
    EXPECT_GE(fine[k], 0.0f);
    EXPECT_LT(fine[k], 1.0f);
    if (k) {
      EXPECT_LE(fine[k - 1], fine[k]);
    }
    inside += fine[k] >= 3.0f / 8 && fine[k] < 4.0f / 8;
  }
  EXPECT_GE(inside, 15);
  // A ray that saw nothing samples its length evenly.
  std::fill(w.begin(), w.end(), 0.0f);
  importance_samples(w.data(), 8, 4, nullptr, fine.data());
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(fine[k], (k + 0.5) / 4, 1e-6);
}

TEST(NerfSampling, RaysPassThroughPixelCentresAndDepthIsUniformInDisparity) {
  lrf::Camera cam;
  cam.width = 8;
  cam.height = 6;
  cam.fx = 7.0, cam.fy = 7.5, cam.cx = 4.2, cam.cy = 2.9;
  cam.R = Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()).toRotationMatrix();
  cam.t = Eigen::Vector3d(0.5, -0.2, 1.0);
  double origin[3], direction[3];
  pixel_ray(cam, 5, 2, origin, direction);
  const Eigen::Vector3d p = Eigen::Vector3d(origin[0], origin[1], origin[2]) + 3.0 * Eigen::Vector3d(direction[0], direction[1], direction[2]);
  Eigen::Vector2d pixel;
  double depth;
  ASSERT_TRUE(cam.project(p, &pixel, &depth));
  EXPECT_NEAR(pixel.x(), 5.5, 1e-9);
  EXPECT_NEAR(pixel.y(), 2.5, 1e-9);
  EXPECT_NEAR(depth, 3.0, 1e-9);  // the ray's parameter is camera depth

  SceneBounds b;
  b.near = 2.0;
  b.far = 8.0;
  EXPECT_DOUBLE_EQ(depth_at(b, 0.0), 2.0);
  EXPECT_DOUBLE_EQ(depth_at(b, 1.0), 8.0);
  EXPECT_NEAR(1.0 / depth_at(b, 0.5), 0.5 * (1.0 / 2.0 + 1.0 / 8.0), 1e-12);
}

TEST(NerfSceneBounds, ContractionIsContinuousAndKeepsSpaceInTheGrid) {
  SceneBounds b;
  b.center = Eigen::Vector3d(1, 2, 3);
  b.half = Eigen::Vector3d(2, 1, 4);
  // Inside the box: linear, the box filling the middle half of the grid.
  EXPECT_TRUE(b.grid_coordinates(b.center).isApprox(Eigen::Vector3d(0.5, 0.5, 0.5)));
  EXPECT_TRUE(b.grid_coordinates(Eigen::Vector3d(3, 2, 3)).isApprox(Eigen::Vector3d(0.75, 0.5, 0.5)));
  // Continuous across the box's face, and the far away lands near the grid's boundary, never beyond.
  const Eigen::Vector3d in = b.grid_coordinates(Eigen::Vector3d(3 - 1e-9, 2.3, 3)),
                        out = b.grid_coordinates(Eigen::Vector3d(3 + 1e-9, 2.3, 3));
  EXPECT_LT((in - out).norm(), 1e-8);
  const Eigen::Vector3d far = b.grid_coordinates(Eigen::Vector3d(1e9, -3e8, 5));
  EXPECT_NEAR(far.x(), 1.0, 1e-6);
  EXPECT_GT(far.minCoeff(), 0.0);
  EXPECT_LE(far.maxCoeff(), 1.0);

  // Bounds from points in front of one camera at depths 5..20: near below, far above, box around them.
  lrf::Camera cam;
  cam.width = 100, cam.height = 100, cam.fx = cam.fy = 100, cam.cx = cam.cy = 50;
  std::vector<Eigen::Vector3d> points;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.3, 0.3), z(5.0, 20.0);
  for (int i = 0; i < 500; ++i) {
    const double depth = z(rng);
    points.emplace_back(u(rng) * depth, u(rng) * depth, depth);
  }
  const SceneBounds fit = bounds_from_points({cam}, points, Eigen::Vector3d::Zero(), 1.0);
  EXPECT_LT(fit.near, 5.0);
  EXPECT_GT(fit.near, 4.0);
  EXPECT_GT(fit.far, 20.0);
  EXPECT_LT(fit.far, 25.0);
  EXPECT_NEAR(fit.center.z(), 12.5, 1.0);
  EXPECT_GT(fit.half.z(), 7.0);
  EXPECT_NEAR(fit.unit, fit.half.mean(), 1e-12);
  // Without points: the cameras' sphere.
  const SceneBounds none = bounds_from_points({cam}, {}, Eigen::Vector3d(1, 1, 1), 2.0);
  EXPECT_TRUE(none.center.isApprox(Eigen::Vector3d(1, 1, 1)));
  EXPECT_GT(none.far, none.near);
}

}  // namespace
