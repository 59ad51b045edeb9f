// The fast rasterizer against the float64 reference (values) and central finite differences of the
// reference (gradients).
//
// Tolerances, and why:
// - Values: the kernels run in float32 (relative rounding ~6e-8 per operation) and composite at most a few
//   dozen splats per pixel, so colours in [0, ~1.5] agree to ~1e-6; 1e-4 absolute leaves room for exp()
//   and the conic inversion in float while a wrong rule (a missing clamp, an off-by-half pixel centre, a
//   wrong SH sign) moves values by >= 1e-3. Depth (z ~ 2–6) gets 5e-4.
// - Gradients: central differences of the float64 reference with step h = 1e-5 have truncation error
//   ~h²·f''' (the scenes' splats are >= 1 px wide, so f''' is at most ~1e3 × the gradient scale: ~1e-7
//   relative) and rounding error ~1e-16·|loss|/h ~ 1e-10. The float32 backward sums thousands of
//   pixel contributions, some cancelling, so its error is relative to the gradient's *scale*, not to each
//   entry: an entry passes when |g − fd| <= 1e-3·max|fd over its parameter group| + 1e-2·|fd|.
// - Discontinuities: the image is only piecewise smooth in the inputs (α < 1/255 cut, 0.99 clamp, T < 1e-4
//   termination, tile/radius culling, the Jacobian clamp's kink, SH clamp at 0). The scenes keep most
//   pairs away from them (moderate opacities, splats of a few pixels), and the reference reports a hash of
//   every discrete decision: when ±h lands on different pieces the step is divided by 8 (up to 3 times)
//   and, failing that, the entry is not compared. At most 2% of entries may be skipped, so the test cannot
//   pass by skipping.
#include <gtest/gtest.h>

#include <torch/torch.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "lrf/splat/rasterize.h"
#include "lrf/splat/reference.h"

namespace {

using lrf::splat::RasterSettings;
using lrf::splat::render;
using lrf::splat::render_reference;

struct Scene {
  torch::Tensor means, log_scales, quats, logits, sh;
  RasterSettings settings;
  std::vector<torch::Tensor> params() const { return {means, log_scales, quats, logits, sh}; }
};

// A camera looking at a random cloud of Gaussians: most in view, some over the border, some beyond the
// Jacobian clamp, some behind the camera, a few large opaque ones whose α clamps at 0.99.
Scene make_scene(int64_t n, int64_t channels, int sh_stored, int sh_degree, uint64_t seed, int width = 40,
                 int height = 30) {
  torch::manual_seed(seed);
  std::mt19937 rng(seed);
  Scene s;
  RasterSettings& r = s.settings;
  r.width = width;
  r.height = height;
  r.fx = 1.0 * width;
  r.fy = 1.05 * width;
  r.cx = 0.52 * width;  // off-centre principal point: the two sides' Jacobian clamps differ
  r.cy = 0.47 * height;
  r.R = Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1.0, -0.4).normalized()).toRotationMatrix();
  r.t = Eigen::Vector3d(0.1, -0.2, 0.3);
  r.sh_degree = sh_degree;
  r.background = torch::rand({channels}, torch::kFloat32);

  auto cam = torch::empty({n, 3}, torch::kFloat64);
  std::uniform_real_distribution<double> uz(2.0, 6.0), ux(-0.75, 0.75), uy(-0.7, 0.7);
  for (int64_t i = 0; i < n; ++i) {
    const double z = uz(rng);
    double x = ux(rng) * z, y = uy(rng) * z, zz = z;
    if (i % 13 == 5) zz = -z;  // behind the camera
    cam[i][0] = x, cam[i][1] = y, cam[i][2] = zz;
  }
  // world = Rᵀ (cam − t)
  torch::Tensor Rt = torch::empty({3, 3}, torch::kFloat64), t = torch::empty({3}, torch::kFloat64);
  for (int a = 0; a < 3; ++a) {
    t[a] = r.t(a);
    for (int b = 0; b < 3; ++b) Rt[a][b] = r.R(b, a);
  }
  s.means = ((cam - t).matmul(Rt.t())).to(torch::kFloat32);
  // Scales 0.05–0.25: 0.5–4 px at these depths; anisotropic.
  s.log_scales = (torch::rand({n, 3}) * 1.6 - 3.0);
  s.quats = torch::randn({n, 4});
  // Opacities 0.15–0.6, except every 7th Gaussian: large and nearly opaque (α clamps at 0.99).
  s.logits = torch::rand({n, 1}) * 2.0 - 1.7;
  for (int64_t i = 3; i < n; i += 7) {
    s.logits[i][0] = 6.0;
    s.log_scales[i] += 1.0;
  }
  const int64_t K = (sh_stored + 1) * (sh_stored + 1);
  s.sh = torch::randn({n, K, channels}) * 0.15;
  s.sh.select(1, 0).add_(0.3);
  return s;
}


double max_abs_diff(const torch::Tensor& a, const torch::Tensor& b) {
  return (a.to(torch::kFloat64) - b.to(torch::kFloat64)).abs().max().item<double>();
}

class ForwardMatchesReference : public ::testing::TestWithParam<int> {};

TEST_P(ForwardMatchesReference, ImageAlphaDepthRadii) {
  const int C = GetParam();
  for (uint64_t seed : {1, 2, 3}) {
    Scene s = make_scene(48, C, 3, static_cast<int>(seed % 4), seed);
    torch::NoGradGuard ng;
    auto fast = render(s.means, s.log_scales, s.quats, s.logits, s.sh, s.settings);
    auto ref = render_reference(s.means, s.log_scales, s.quats, s.logits, s.sh, s.settings);
    ASSERT_EQ(fast.image.sizes(), ref.image.sizes());
    EXPECT_LT(max_abs_diff(fast.image, ref.image), 1e-4) << "seed " << seed;
    EXPECT_LT(max_abs_diff(fast.alpha, ref.alpha), 1e-4) << "seed " << seed;
    EXPECT_LT(max_abs_diff(fast.depth, ref.depth), 5e-4) << "seed " << seed;
    EXPECT_TRUE(torch::equal(fast.radii, ref.radii)) << "seed " << seed;
    // The scene is not trivial: something is drawn, something is culled, and some pixels are covered.
    EXPECT_GT(ref.alpha.max().item<double>(), 0.9);
    EXPECT_GT((fast.radii == 0).sum().item<int64_t>(), 0);
    EXPECT_GT((fast.radii > 0).sum().item<int64_t>(), 20);
  }
}

INSTANTIATE_TEST_SUITE_P(Channels, ForwardMatchesReference, ::testing::Values(1, 3, 4, 32));

}  // namespace
