// FLIP and MS-SSIM against plain float64 references written from the published equations (direct 2-D
// kernels and loops, no separability, no OpenCV), and on cases whose value is known in closed form.
#include <array>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "lrf/core/error.h"
#include "lrf/eval/flip.h"
#include "lrf/eval/ms_ssim.h"

namespace {

using Plane = std::vector<std::vector<double>>;  // [row][column]

Plane plane_of(const torch::Tensor& image, int c) {
  auto x = image.to(torch::kFloat64).clamp(0, 1);
  const int h = static_cast<int>(x.size(1)), w = static_cast<int>(x.size(2));
  Plane p(h, std::vector<double>(w));
  for (int i = 0; i < h; ++i)
    for (int j = 0; j < w; ++j) p[i][j] = x[c][i][j].item<double>();
  return p;
}

// scipy.signal.convolve2d(mode='same', boundary='symm'): a true convolution (kernel flipped), the image
// mirrored with its edge pixel repeated.
Plane convolve_symmetric(const Plane& x, const Plane& kernel) {
  const int h = static_cast<int>(x.size()), w = static_cast<int>(x[0].size());
  const int r = static_cast<int>(kernel.size()) / 2;
  auto mirror = [](int i, int n) {
    while (i < 0 || i >= n) i = i < 0 ? -i - 1 : 2 * n - 1 - i;
    return i;
  };
  Plane out(h, std::vector<double>(w, 0.0));
  for (int i = 0; i < h; ++i)
    for (int j = 0; j < w; ++j)
      for (int u = -r; u <= r; ++u)
        for (int v = -r; v <= r; ++v) out[i][j] += kernel[r - u][r - v] * x[mirror(i + u, h)][mirror(j + v, w)];
  return out;
}

// ---- FLIP, step by step as in the paper -------------------------------------------------------------

// linear sRGB -> XYZ (D65), the fractions FLIP's authors use.
const double kM[3][3] = {{10135552.0 / 24577794, 8788810.0 / 24577794, 4435075.0 / 24577794},
                         {2613072.0 / 12288897, 8788810.0 / 12288897, 887015.0 / 12288897},
                         {1425312.0 / 73733382, 8788810.0 / 73733382, 70074185.0 / 73733382}};

std::array<double, 3> mul(const double m[3][3], const std::array<double, 3>& v) {
  return {m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2], m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
          m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2]};
}

std::array<double, 3> white() { return mul(kM, {1, 1, 1}); }

std::array<double, 3> xyz_to_rgb(const std::array<double, 3>& xyz) {
  // Cramer's rule on kM.
  const double(&m)[3][3] = kM;
  const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                     m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  std::array<double, 3> out{};
  for (int k = 0; k < 3; ++k) {
    double a[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) a[i][j] = j == k ? xyz[i] : m[i][j];
    out[k] = (a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
              a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])) /
             det;
  }
  return out;
}

std::array<double, 3> hunt_lab(const std::array<double, 3>& rgb) {
  const auto xyz = mul(kM, rgb);
  const auto w = white();
  auto f = [](double t) {
    const double d = 6.0 / 29.0;
    return t > d * d * d ? std::pow(t, 1.0 / 3.0) : t / (3 * d * d) + 4.0 / 29.0;
  };
  const double l = 116 * f(xyz[1] / w[1]) - 16;
  const double a = 500 * (f(xyz[0] / w[0]) - f(xyz[1] / w[1]));
  const double b = 200 * (f(xyz[1] / w[1]) - f(xyz[2] / w[2]));
  return {l, l / 100 * a, l / 100 * b};
}

double hyab(const std::array<double, 3>& p, const std::array<double, 3>& q) {
  return std::abs(p[0] - q[0]) + std::sqrt((p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2]));
}

Plane csf_kernel(double a1, double b1, double a2, double b2, double ppd) {
  const int r = static_cast<int>(std::ceil(3 * std::sqrt(0.04 / (2 * M_PI * M_PI)) * ppd));
  Plane k(2 * r + 1, std::vector<double>(2 * r + 1));
  double sum = 0;
  for (int i = -r; i <= r; ++i)
    for (int j = -r; j <= r; ++j) {
      const double z = (i * i + j * j) / (ppd * ppd);
      k[i + r][j + r] = a1 * std::sqrt(M_PI / b1) * std::exp(-M_PI * M_PI * z / b1) +
                        a2 * std::sqrt(M_PI / b2) * std::exp(-M_PI * M_PI * z / b2);
      sum += k[i + r][j + r];
    }
  for (auto& row : k)
    for (double& v : row) v /= sum;
  return k;
}

// The x-direction edge or point detector; the y one is its transpose.
Plane detector(bool edge, double ppd) {
  const double sd = 0.5 * 0.082 * ppd;
  const int r = static_cast<int>(std::ceil(3 * sd));
  Plane k(2 * r + 1, std::vector<double>(2 * r + 1));
  double pos = 0, neg = 0;
  for (int y = -r; y <= r; ++y)
    for (int x = -r; x <= r; ++x) {
      const double g = std::exp(-(x * x + y * y) / (2 * sd * sd));
      const double v = edge ? -x * g : (x * x / (sd * sd) - 1) * g;
      k[y + r][x + r] = v;
      (v > 0 ? pos : neg) += v;
    }
  for (auto& row : k)
    for (double& v : row) v = v > 0 ? v / pos : v / -neg;
  return k;
}

Plane transpose(const Plane& k) {
  Plane t(k[0].size(), std::vector<double>(k.size()));
  for (size_t i = 0; i < k.size(); ++i)
    for (size_t j = 0; j < k[0].size(); ++j) t[j][i] = k[i][j];
  return t;
}

double reference_flip(const torch::Tensor& reference, const torch::Tensor& test, double ppd) {
  const int h = static_cast<int>(reference.size(1)), w = static_cast<int>(reference.size(2));
  auto linear = [](double v) { return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4); };
  auto opponent = [&](const torch::Tensor& image) {
    std::array<Plane, 3> rgb = {plane_of(image, 0), plane_of(image, 1), plane_of(image, 2)};
    std::array<Plane, 3> ycxcz;
    for (auto& p : ycxcz) p.assign(h, std::vector<double>(w));
    const auto wt = white();
    for (int i = 0; i < h; ++i)
      for (int j = 0; j < w; ++j) {
        const auto xyz = mul(kM, {linear(rgb[0][i][j]), linear(rgb[1][i][j]), linear(rgb[2][i][j])});
        ycxcz[0][i][j] = 116 * xyz[1] / wt[1] - 16;
        ycxcz[1][i][j] = 500 * (xyz[0] / wt[0] - xyz[1] / wt[1]);
        ycxcz[2][i][j] = 200 * (xyz[1] / wt[1] - xyz[2] / wt[2]);
      }
    return ycxcz;
  };
  const auto ref = opponent(reference), tst = opponent(test);
  const std::array<Plane, 3> kernels = {csf_kernel(1, 0.0047, 0, 1e-5, ppd), csf_kernel(1, 0.0053, 0, 1e-5, ppd),
                                        csf_kernel(34.1, 0.04, 13.5, 0.025, ppd)};
  auto filtered_lab = [&](const std::array<Plane, 3>& o) {
    std::array<Plane, 3> f;
    for (int c = 0; c < 3; ++c) f[c] = convolve_symmetric(o[c], kernels[c]);
    std::vector<std::vector<std::array<double, 3>>> lab(h, std::vector<std::array<double, 3>>(w));
    const auto wt = white();
    for (int i = 0; i < h; ++i)
      for (int j = 0; j < w; ++j) {
        const double yn = (f[0][i][j] + 16) / 116;
        auto rgb = xyz_to_rgb({(f[1][i][j] / 500 + yn) * wt[0], yn * wt[1], (yn - f[2][i][j] / 200) * wt[2]});
        for (double& v : rgb) v = std::min(1.0, std::max(0.0, v));
        lab[i][j] = hunt_lab(rgb);
      }
    return lab;
  };
  const auto lab_ref = filtered_lab(ref), lab_tst = filtered_lab(tst);
  auto luminance = [&](const Plane& y) {
    Plane l = y;
    for (auto& row : l)
      for (double& v : row) v = (v + 16) / 116;
    return l;
  };
  const Plane edge = detector(true, ppd), point = detector(false, ppd);
  const Plane edge_t = transpose(edge), point_t = transpose(point);
  auto norm = [&](const Plane& l, const Plane& kx, const Plane& ky) {
    const Plane fx = convolve_symmetric(l, kx), fy = convolve_symmetric(l, ky);
    Plane n = fx;
    for (int i = 0; i < h; ++i)
      for (int j = 0; j < w; ++j) n[i][j] = std::sqrt(fx[i][j] * fx[i][j] + fy[i][j] * fy[i][j]);
    return n;
  };
  const Plane yr = luminance(ref[0]), yt = luminance(tst[0]);
  const Plane er = norm(yr, edge, edge_t), et = norm(yt, edge, edge_t);
  const Plane pr = norm(yr, point, point_t), pt = norm(yt, point, point_t);
  const double cmax = std::pow(hyab(hunt_lab({0, 1, 0}), hunt_lab({0, 0, 1})), 0.7);
  double sum = 0;
  for (int i = 0; i < h; ++i)
    for (int j = 0; j < w; ++j) {
      const double e = std::pow(hyab(lab_ref[i][j], lab_tst[i][j]), 0.7);
      const double c = e < 0.4 * cmax ? 0.95 / (0.4 * cmax) * e : 0.95 + (e - 0.4 * cmax) / (0.6 * cmax) * 0.05;
      const double f = std::pow(std::max(std::abs(er[i][j] - et[i][j]), std::abs(pr[i][j] - pt[i][j])) / std::sqrt(2.0), 0.5);
      sum += std::pow(c, 1 - f);
    }
  return sum / (h * w);
}

// ---- MS-SSIM ----------------------------------------------------------------------------------------

double reference_ms_ssim(const torch::Tensor& a, const torch::Tensor& b) {
  const double weights[5] = {0.0448, 0.2856, 0.3001, 0.2363, 0.1333};
  const double c1 = 1e-4, c2 = 9e-4;
  double window[11][11], wsum = 0;
  for (int i = 0; i < 11; ++i)
    for (int j = 0; j < 11; ++j) wsum += window[i][j] = std::exp(-((i - 5) * (i - 5) + (j - 5) * (j - 5)) / 4.5);
  double total = 0;
  for (int c = 0; c < a.size(0); ++c) {
    Plane x = plane_of(a, c), y = plane_of(b, c);
    double value = 1;
    for (int s = 0; s < 5; ++s) {
      const int h = static_cast<int>(x.size()), w = static_cast<int>(x[0].size());
      double l_sum = 0, cs_sum = 0;
      int count = 0;
      for (int i = 0; i + 11 <= h; ++i)
        for (int j = 0; j + 11 <= w; ++j) {
          double mx = 0, my = 0, xx = 0, yy = 0, xy = 0;
          for (int u = 0; u < 11; ++u)
            for (int v = 0; v < 11; ++v) {
              const double g = window[u][v] / wsum, p = x[i + u][j + v], q = y[i + u][j + v];
              mx += g * p;
              my += g * q;
              xx += g * p * p;
              yy += g * q * q;
              xy += g * p * q;
            }
          l_sum += (2 * mx * my + c1) / (mx * mx + my * my + c1);
          cs_sum += (2 * (xy - mx * my) + c2) / (xx - mx * mx + yy - my * my + c2);
          ++count;
        }
      value *= std::pow(std::max(0.0, cs_sum / count), weights[s]);
      if (s == 4) {
        value *= std::pow(std::max(0.0, l_sum / count), weights[s]);
        break;
      }
      Plane hx(h / 2, std::vector<double>(w / 2)), hy = hx;
      for (int i = 0; i < h / 2; ++i)
        for (int j = 0; j < w / 2; ++j) {
          hx[i][j] = (x[2 * i][2 * j] + x[2 * i + 1][2 * j] + x[2 * i][2 * j + 1] + x[2 * i + 1][2 * j + 1]) / 4;
          hy[i][j] = (y[2 * i][2 * j] + y[2 * i + 1][2 * j] + y[2 * i][2 * j + 1] + y[2 * i + 1][2 * j + 1]) / 4;
        }
      x = hx;
      y = hy;
    }
    total += value;
  }
  return total / static_cast<double>(a.size(0));
}

// A textured test image: smooth gradients, a sharp-edged square and noise.
torch::Tensor textured(int h, int w, int seed) {
  torch::manual_seed(seed);
  auto yy = torch::linspace(0, 1, h, torch::kFloat64).view({1, h, 1});
  auto xx = torch::linspace(0, 1, w, torch::kFloat64).view({1, 1, w});
  auto img = torch::cat({0.3 + 0.4 * xx * yy, 0.6 - 0.3 * yy + 0 * xx, 0.2 + 0.5 * xx + 0 * yy});
  img.index_put_({torch::indexing::Slice(), torch::indexing::Slice(h / 4, h / 2), torch::indexing::Slice(w / 3, 2 * w / 3)}, 0.9);
  return (img + 0.05 * torch::randn({3, h, w}, torch::kFloat64)).clamp(0, 1);
}

// A separable box blur of odd side k with mirrored borders, in libtorch.
torch::Tensor box_blur(const torch::Tensor& image, int k) {
  auto x = image.unsqueeze(0);
  auto padded = torch::nn::functional::pad(x, torch::nn::functional::PadFuncOptions({k / 2, k / 2, k / 2, k / 2}).mode(torch::kReflect));
  auto kernel = torch::full({3, 1, k, k}, 1.0 / (k * k), torch::kFloat64);
  return torch::conv2d(padded, kernel, torch::Tensor(), torch::IntArrayRef{1}, torch::IntArrayRef{0}, torch::IntArrayRef{1}, 3)
      .squeeze(0);
}

}  // namespace

// The fast (separable, OpenCV) FLIP equals the direct 2-D reference on a textured pair. The two differ
// only in summation order, so they agree to float64 rounding of sums of ~441 terms, far below 1e-9.
TEST(EvalFlip, MatchesTheDirectReference) {
  const double ppd = lrf::flip_default_pixels_per_degree();
  EXPECT_NEAR(ppd, 67.0206, 1e-4);
  auto a = textured(30, 37, 1);
  auto b = (box_blur(a, 3) + 0.02).clamp(0, 1);
  const double fast = lrf::flip(a, b), slow = reference_flip(a, b, ppd);
  EXPECT_GT(fast, 0.01);
  EXPECT_NEAR(fast, slow, 1e-9);
  // At another viewing distance too (smaller kernels than the image, and larger ones).
  EXPECT_NEAR(lrf::flip(a, b, 20.0), reference_flip(a, b, 20.0), 1e-9);
  EXPECT_NEAR(lrf::flip(a, b, 90.0), reference_flip(a, b, 90.0), 1e-9);
  // The map has one value per pixel in [0, 1].
  auto map = lrf::flip_map(a, b);
  EXPECT_EQ(map.sizes(), (torch::IntArrayRef{30, 37}));
  EXPECT_GE(map.min().item<double>(), 0.0);
  EXPECT_LE(map.max().item<double>(), 1.0);
}

TEST(EvalFlip, KnownCases) {
  auto a = textured(32, 32, 2);
  EXPECT_EQ(lrf::flip(a, a), 0.0);
  // Uniform black against uniform white: the filters keep a constant image constant and find no
  // features, so FLIP is the colour term alone. L* is 0 and 100, a* = b* = 0: HyAB = 100, and
  // 100^0.7 = 25.119. The top of the scale is HyAB(green, blue)^0.7 = 203.302^0.7 = 41.276, and errors
  // above 0.4 of it map linearly onto [0.95, 1]: 0.95 + (25.119 - 16.510) / (41.276 - 16.510) * 0.05.
  auto black = torch::zeros({3, 24, 24}), white_image = torch::ones({3, 24, 24});
  EXPECT_NEAR(lrf::flip(black, white_image), 0.9673797614921327, 1e-9);
  // Uniform grey 0.5 against 0.6 (L* 53.389 and 63.223): below the knee, 0.95 / (0.4 cmax) * 9.834^0.7.
  auto g5 = torch::full({3, 24, 24}, 0.5, torch::kFloat64), g6 = torch::full({3, 24, 24}, 0.6, torch::kFloat64);
  // The feature term is a square root: the detectors' float64 rounding on a flat image (~1e-16) becomes
  // an exponent of ~1e-8, so this case holds to 1e-7 rather than to rounding.
  EXPECT_NEAR(lrf::flip(g5, g6), 0.2850130025117048, 1e-7);
  // A uniform shift of a textured image: a larger shift is a larger error.
  const double small = lrf::flip(a, (a + 0.02).clamp(0, 1)), large = lrf::flip(a, (a + 0.1).clamp(0, 1));
  EXPECT_GT(small, 0.0);
  EXPECT_GT(large, small);
  // Blur: more blur, more error; FLIP is symmetric only in its colour term, so no symmetry is asserted.
  const double b3 = lrf::flip(a, box_blur(a, 3)), b7 = lrf::flip(a, box_blur(a, 7));
  EXPECT_GT(b3, 0.0);
  EXPECT_GT(b7, b3);
}

TEST(EvalFlip, RejectsBadShapes) {
  EXPECT_THROW(lrf::flip(torch::zeros({3, 8, 8}), torch::zeros({3, 8, 9})), lrf::Error);
  EXPECT_THROW(lrf::flip(torch::zeros({1, 8, 8}), torch::zeros({1, 8, 8})), lrf::Error);
  EXPECT_THROW(lrf::flip(torch::zeros({8, 8}), torch::zeros({8, 8})), lrf::Error);
  EXPECT_THROW(lrf::flip(torch::zeros({3, 8, 8}), torch::zeros({3, 8, 8}), 0.0), lrf::Error);
}

// The OpenCV MS-SSIM equals the direct reference; sums of 121 products in another order agree to 1e-12.
TEST(EvalMsSsim, MatchesTheDirectReference) {
  auto a = textured(lrf::kMsSsimMinSide, lrf::kMsSsimMinSide + 7, 3);
  auto b = (box_blur(a, 3) + 0.03 * torch::randn_like(a)).clamp(0, 1);
  const auto fast = lrf::ms_ssim(a, b);
  ASSERT_TRUE(fast.has_value());
  EXPECT_NEAR(*fast, reference_ms_ssim(a, b), 1e-12);
  EXPECT_LT(*fast, 0.99);
  EXPECT_GT(*fast, 0.3);
}

TEST(EvalMsSsim, KnownCases) {
  const int n = lrf::kMsSsimMinSide;
  auto a = textured(n, n, 4);
  EXPECT_NEAR(*lrf::ms_ssim(a, a), 1.0, 1e-12);
  // A uniform shift (no clamping: the image stays inside [0, 0.95]) leaves every variance and
  // covariance, so every contrast-structure term is exactly 1; only the coarsest luminance term drops.
  auto dim = a * 0.9;
  const double shifted = *lrf::ms_ssim(dim, dim + 0.05);
  EXPECT_LT(shifted, 1.0);
  EXPECT_GT(shifted, 0.99);
  EXPECT_NEAR(shifted, reference_ms_ssim(dim, dim + 0.05), 1e-12);
  // Blur lowers it, more blur lowers it more.
  const double b3 = *lrf::ms_ssim(a, box_blur(a, 3)), b7 = *lrf::ms_ssim(a, box_blur(a, 7));
  EXPECT_LT(b3, 1.0);
  EXPECT_LT(b7, b3);
  // Too small for five scales: no value rather than another metric.
  EXPECT_FALSE(lrf::ms_ssim(torch::zeros({3, n - 1, n}), torch::zeros({3, n - 1, n})).has_value());
  EXPECT_THROW(lrf::ms_ssim(torch::zeros({3, n, n}), torch::zeros({3, n, n + 1})), lrf::Error);
}
