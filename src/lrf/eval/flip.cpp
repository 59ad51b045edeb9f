#include "lrf/eval/flip.h"

#include <array>
#include <cmath>
#include <sstream>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "lrf/core/error.h"

namespace lrf {
namespace {

using Planes = std::array<cv::Mat, 3>;  // three H x W CV_64F planes

// The published constants of LDR-FLIP.
constexpr double kQc = 0.7;            // exponent on the colour difference
constexpr double kQf = 0.5;            // exponent on the feature difference
constexpr double kPc = 0.4, kPt = 0.95;  // error redistribution: the lower pc of the range maps to pt
constexpr double kFeatureWidthDeg = 0.082;

// sRGB primaries, D65 white: linear RGB -> XYZ.
constexpr double kRgbToXyz[3][3] = {{10135552.0 / 24577794.0, 8788810.0 / 24577794.0, 4435075.0 / 24577794.0},
                                    {2613072.0 / 12288897.0, 8788810.0 / 12288897.0, 887015.0 / 12288897.0},
                                    {1425312.0 / 73733382.0, 8788810.0 / 73733382.0, 70074185.0 / 73733382.0}};

cv::Matx33d rgb_to_xyz() { return cv::Matx33d(&kRgbToXyz[0][0]); }
cv::Vec3d white_xyz() { return rgb_to_xyz() * cv::Vec3d(1, 1, 1); }

double srgb_to_linear(double v) { return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4); }

double lab_f(double t) {
  constexpr double d = 6.0 / 29.0;
  return t > d * d * d ? std::cbrt(t) : t / (3.0 * d * d) + 4.0 / 29.0;
}

// Linear RGB -> CIE L*a*b* with the Hunt adjustment (chroma scaled by L*/100), per pixel.
cv::Vec3d hunt_lab(const cv::Vec3d& linear_rgb) {
  const cv::Vec3d xyz = rgb_to_xyz() * linear_rgb, w = white_xyz();
  const double fx = lab_f(xyz[0] / w[0]), fy = lab_f(xyz[1] / w[1]), fz = lab_f(xyz[2] / w[2]);
  const double l = 116.0 * fy - 16.0;
  return {l, 0.01 * l * 500.0 * (fx - fy), 0.01 * l * 200.0 * (fy - fz)};
}

double hyab(const cv::Vec3d& a, const cv::Vec3d& b) {
  return std::abs(a[0] - b[0]) + std::hypot(a[1] - b[1], a[2] - b[2]);
}

// The largest colour difference (green against blue), raised to qc: the top of the error scale.
double max_colour_difference() {
  return std::pow(hyab(hunt_lab({0, 1, 0}), hunt_lab({0, 0, 1})), kQc);
}

Planes srgb_to_ycxcz(const torch::Tensor& image) {
  auto x = image.to(torch::kCPU, torch::kFloat64).clamp(0.0, 1.0).contiguous();
  const int h = static_cast<int>(x.size(1)), w = static_cast<int>(x.size(2));
  const double* p = x.data_ptr<double>();
  const size_t plane = static_cast<size_t>(h) * static_cast<size_t>(w);
  Planes out = {cv::Mat(h, w, CV_64F), cv::Mat(h, w, CV_64F), cv::Mat(h, w, CV_64F)};
  const cv::Matx33d m = rgb_to_xyz();
  const cv::Vec3d white = white_xyz();
  for (size_t i = 0; i < plane; ++i) {
    const cv::Vec3d lin(srgb_to_linear(p[i]), srgb_to_linear(p[plane + i]), srgb_to_linear(p[2 * plane + i]));
    const cv::Vec3d xyz = m * lin;
    const double xn = xyz[0] / white[0], yn = xyz[1] / white[1], zn = xyz[2] / white[2];
    out[0].ptr<double>()[i] = 116.0 * yn - 16.0;
    out[1].ptr<double>()[i] = 500.0 * (xn - yn);
    out[2].ptr<double>()[i] = 200.0 * (yn - zn);
  }
  return out;
}

// exp(-pi^2 (k / ppd)^2 / b) for k = -r..r: one factor of a separable 2-D Gaussian of the CSF.
cv::Mat csf_factor(double b, int radius, double ppd) {
  cv::Mat g(2 * radius + 1, 1, CV_64F);
  for (int k = -radius; k <= radius; ++k) {
    const double x = k / ppd;
    g.at<double>(k + radius) = std::exp(-M_PI * M_PI * x * x / b);
  }
  return g;
}

// Convolves a plane with the channel's contrast sensitivity kernel a1 sqrt(pi/b1) G_b1 + a2 sqrt(pi/b2)
// G_b2 over a (2r+1)^2 window, normalised to sum 1. Each Gaussian is separable, so the kernel is applied
// as a weighted sum of separable filters.
cv::Mat csf_filter(const cv::Mat& plane, double a1, double b1, double a2, double b2, int radius, double ppd) {
  const cv::Mat g1 = csf_factor(b1, radius, ppd), g2 = csf_factor(b2, radius, ppd);
  const double w1 = a1 * std::sqrt(M_PI / b1), w2 = a2 * std::sqrt(M_PI / b2);
  const double s1 = cv::sum(g1)[0], s2 = cv::sum(g2)[0];
  const double total = w1 * s1 * s1 + w2 * s2 * s2;
  cv::Mat out;
  cv::sepFilter2D(plane, out, CV_64F, g1, g1, cv::Point(-1, -1), 0.0, cv::BORDER_REFLECT);
  out *= w1 / total;
  if (w2 != 0.0) {
    cv::Mat second;
    cv::sepFilter2D(plane, second, CV_64F, g2, g2, cv::Point(-1, -1), 0.0, cv::BORDER_REFLECT);
    out += second * (w2 / total);
  }
  return out;
}

// The filtered opponent planes back in Hunt-adjusted L*a*b*, after clamping to the RGB cube.
std::vector<cv::Vec3d> filtered_hunt_lab(const Planes& ycxcz, double ppd) {
  // All three kernels share the radius of the widest one (b = 0.04, the blue-yellow channel).
  const int radius = static_cast<int>(std::ceil(3.0 * std::sqrt(0.04 / (2.0 * M_PI * M_PI)) * ppd));
  const Planes f = {csf_filter(ycxcz[0], 1.0, 0.0047, 0.0, 1e-5, radius, ppd),
                    csf_filter(ycxcz[1], 1.0, 0.0053, 0.0, 1e-5, radius, ppd),
                    csf_filter(ycxcz[2], 34.1, 0.04, 13.5, 0.025, radius, ppd)};
  const cv::Matx33d to_rgb = rgb_to_xyz().inv();
  const cv::Vec3d white = white_xyz();
  const size_t n = f[0].total();
  std::vector<cv::Vec3d> lab(n);
  for (size_t i = 0; i < n; ++i) {
    const double yn = (f[0].ptr<double>()[i] + 16.0) / 116.0;
    const cv::Vec3d xyz((f[1].ptr<double>()[i] / 500.0 + yn) * white[0], yn * white[1],
                        (yn - f[2].ptr<double>()[i] / 200.0) * white[2]);
    cv::Vec3d rgb = to_rgb * xyz;
    for (int c = 0; c < 3; ++c) rgb[c] = std::min(1.0, std::max(0.0, rgb[c]));
    lab[i] = hunt_lab(rgb);
  }
  return lab;
}

// The two factors of the separable edge (first derivative) or point (second derivative) detector along
// x; along y the factor is the plain Gaussian. Positive weights sum to 1 and negative ones to -1.
std::pair<cv::Mat, cv::Mat> feature_factors(bool edge, double ppd) {
  const double sd = 0.5 * kFeatureWidthDeg * ppd;
  const int radius = static_cast<int>(std::ceil(3.0 * sd));
  cv::Mat along(2 * radius + 1, 1, CV_64F), across(2 * radius + 1, 1, CV_64F);
  double positive = 0.0, negative = 0.0;
  for (int k = -radius; k <= radius; ++k) {
    const double g = std::exp(-double(k) * k / (2.0 * sd * sd));
    const double d = edge ? -k * g : (double(k) * k / (sd * sd) - 1.0) * g;
    along.at<double>(k + radius) = d;
    across.at<double>(k + radius) = g;
    (d > 0 ? positive : negative) += d;
  }
  for (int k = 0; k < along.rows; ++k) {
    double& d = along.at<double>(k);
    d = d > 0 ? d / positive : d / -negative;
  }
  across /= cv::sum(across)[0];
  return {along, across};
}

// |(response along x, response along y)| of one detector at every pixel.
cv::Mat feature_magnitude(const cv::Mat& luminance, bool edge, double ppd) {
  const auto [along, across] = feature_factors(edge, ppd);
  cv::Mat fx, fy, magnitude;
  cv::sepFilter2D(luminance, fx, CV_64F, along, across, cv::Point(-1, -1), 0.0, cv::BORDER_REFLECT);
  cv::sepFilter2D(luminance, fy, CV_64F, across, along, cv::Point(-1, -1), 0.0, cv::BORDER_REFLECT);
  cv::magnitude(fx, fy, magnitude);
  return magnitude;
}

void check_images(const torch::Tensor& a, const torch::Tensor& b) {
  if (!a.defined() || !b.defined()) fail("flip: undefined image");
  if (a.dim() != 3 || a.size(0) != 3 || a.sizes() != b.sizes() || a.size(1) < 1 || a.size(2) < 1) {
    std::ostringstream s;
    s << "flip: expected two [3, H, W] RGB images of the same size, got " << a.sizes() << " and " << b.sizes();
    fail(s.str());
  }
}

}  // namespace

double flip_default_pixels_per_degree() { return 0.7 * (3840.0 / 0.7) * (M_PI / 180.0); }

torch::Tensor flip_map(const torch::Tensor& reference, const torch::Tensor& test, double ppd) {
  check_images(reference, test);
  if (!(ppd > 0.0)) fail("flip: pixels per degree must be positive");
  torch::NoGradGuard no_grad;
  const Planes ref = srgb_to_ycxcz(reference), tst = srgb_to_ycxcz(test);
  const std::vector<cv::Vec3d> lab_ref = filtered_hunt_lab(ref, ppd), lab_tst = filtered_hunt_lab(tst, ppd);

  // The feature detectors see the normalised luminance Y / Y_white = (Y_ycxcz + 16) / 116.
  auto luminance = [](const cv::Mat& y) {
    cv::Mat l;
    y.convertTo(l, CV_64F, 1.0 / 116.0, 16.0 / 116.0);
    return l;
  };
  const cv::Mat y_ref = luminance(ref[0]), y_tst = luminance(tst[0]);
  const cv::Mat edges_ref = feature_magnitude(y_ref, true, ppd), edges_tst = feature_magnitude(y_tst, true, ppd);
  const cv::Mat points_ref = feature_magnitude(y_ref, false, ppd), points_tst = feature_magnitude(y_tst, false, ppd);

  const double cmax = max_colour_difference(), knee = kPc * cmax;
  const int h = static_cast<int>(reference.size(1)), w = static_cast<int>(reference.size(2));
  auto out = torch::empty({h, w}, torch::kFloat64);
  double* o = out.data_ptr<double>();
  for (size_t i = 0; i < lab_ref.size(); ++i) {
    const double e = std::pow(hyab(lab_ref[i], lab_tst[i]), kQc);
    const double colour = e < knee ? (kPt / knee) * e : kPt + (e - knee) / (cmax - knee) * (1.0 - kPt);
    const double edge = std::abs(edges_ref.ptr<double>()[i] - edges_tst.ptr<double>()[i]);
    const double point = std::abs(points_ref.ptr<double>()[i] - points_tst.ptr<double>()[i]);
    const double feature = std::pow(std::max(edge, point) / std::sqrt(2.0), kQf);
    o[i] = std::pow(colour, 1.0 - feature);
  }
  return out;
}

double flip(const torch::Tensor& reference, const torch::Tensor& test, double ppd) {
  return flip_map(reference, test, ppd).mean().item<double>();
}

}  // namespace lrf
