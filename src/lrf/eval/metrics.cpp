#include "lrf/eval/metrics.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "lrf/core/error.h"

namespace lrf {
namespace {

constexpr int kWindow = 11;
constexpr double kSigma = 1.5;

std::string shape_string(const torch::Tensor& t) {
  std::ostringstream s;
  s << t.sizes();
  return s.str();
}

// Both tensors defined, floating point (or integer: converted), same shape; `dims` 0 = any rank.
void check_pair(const char* what, const torch::Tensor& a, const torch::Tensor& b, int dims) {
  if (!a.defined() || !b.defined()) fail(std::string(what) + ": undefined tensor");
  if (a.sizes() != b.sizes()) {
    fail(std::string(what) + ": shapes differ: " + shape_string(a) + " vs " + shape_string(b));
  }
  if (dims > 0 && a.dim() != dims) {
    fail(std::string(what) + ": expected a [C, H, W] image, got shape " + shape_string(a));
  }
  if (a.numel() == 0) fail(std::string(what) + ": empty image");
}

double psnr_from_mse(double mse_value, double peak) {
  if (!(mse_value > 0.0)) return kPsnrCapDb;
  return std::min(kPsnrCapDb, 10.0 * std::log10(peak * peak / mse_value));
}

torch::Tensor clamped64(const torch::Tensor& t, double max) {
  return t.to(torch::kCPU, torch::kFloat64).clamp(0.0, max);
}

// 3DGS's window: exp(-(x - 5)² / (2σ²)) for x = 0..10, normalised to sum 1. The 11×11 window is the
// outer product of this with itself, so the blur runs as two 1-D passes; with zero padding that is
// exactly the 2-D convolution (padded rows and columns contribute zero either way).
cv::Mat gaussian_1d() {
  cv::Mat g(kWindow, 1, CV_64F);
  for (int i = 0; i < kWindow; ++i) {
    double x = i - kWindow / 2;
    g.at<double>(i) = std::exp(-(x * x) / (2.0 * kSigma * kSigma));
  }
  return g / cv::sum(g)[0];
}

// Same-size Gaussian blur with zero padding of each channel of a contiguous [C, H, W] float64 tensor.
// OpenCV's separable filter runs in float64 too; a whole 1008×756 SSIM takes 0.7 s with it against 5.7 s
// with libtorch's float64 grouped convolution, which has no optimised kernel.
torch::Tensor blur(const torch::Tensor& x) {
  static const cv::Mat g = gaussian_1d();
  const int c = static_cast<int>(x.size(0)), h = static_cast<int>(x.size(1)), w = static_cast<int>(x.size(2));
  auto out = torch::empty_like(x);
  for (int k = 0; k < c; ++k) {
    cv::Mat src(h, w, CV_64F, x[k].data_ptr<double>());
    cv::Mat dst(h, w, CV_64F, out[k].data_ptr<double>());
    cv::sepFilter2D(src, dst, CV_64F, g, g, cv::Point(-1, -1), 0.0, cv::BORDER_CONSTANT);
  }
  return out;
}

}  // namespace

double mse(const torch::Tensor& a, const torch::Tensor& b) {
  check_pair("mse", a, b, 0);
  torch::NoGradGuard no_grad;
  auto d = a.to(torch::kCPU, torch::kFloat64) - b.to(torch::kCPU, torch::kFloat64);
  return (d * d).mean().item<double>();
}

double psnr_unclamped(const torch::Tensor& a, const torch::Tensor& b, double peak) {
  if (!(peak > 0.0)) fail("psnr: peak value must be positive, got " + std::to_string(peak));
  return psnr_from_mse(mse(a, b), peak);
}

double psnr(const torch::Tensor& a, const torch::Tensor& b, double max) {
  check_pair("psnr", a, b, 3);
  if (!(max > 0.0)) fail("psnr: max value must be positive, got " + std::to_string(max));
  torch::NoGradGuard no_grad;
  return psnr_from_mse(mse(clamped64(a, max), clamped64(b, max)), max);
}

double ssim(const torch::Tensor& a, const torch::Tensor& b, double max) {
  check_pair("ssim", a, b, 3);
  if (!(max > 0.0)) fail("ssim: max value must be positive, got " + std::to_string(max));
  torch::NoGradGuard no_grad;
  auto x = clamped64(a, max).contiguous();
  auto y = clamped64(b, max).contiguous();
  const double c1 = (0.01 * max) * (0.01 * max);
  const double c2 = (0.03 * max) * (0.03 * max);
  auto mu_x = blur(x);
  auto mu_y = blur(y);
  auto mu_xx = mu_x * mu_x;
  auto mu_yy = mu_y * mu_y;
  auto mu_xy = mu_x * mu_y;
  auto var_x = blur(x * x) - mu_xx;
  auto var_y = blur(y * y) - mu_yy;
  auto cov_xy = blur(x * y) - mu_xy;
  auto map = ((2.0 * mu_xy + c1) * (2.0 * cov_xy + c2)) / ((mu_xx + mu_yy + c1) * (var_x + var_y + c2));
  return map.mean().item<double>();
}

torch::Tensor image_to_chw(const cv::Mat& image) {
  if (image.empty()) fail("image_to_chw: empty image");
  if (image.depth() != CV_8U && image.depth() != CV_32F) {
    fail("image_to_chw: expected an 8-bit or float32 image, got OpenCV depth " + std::to_string(image.depth()));
  }
  cv::Mat f;
  image.convertTo(f, CV_32F, image.depth() == CV_8U ? 1.0 / 255.0 : 1.0);  // also makes it continuous
  if (!f.isContinuous()) f = f.clone();
  auto hwc = torch::from_blob(f.data, {f.rows, f.cols, f.channels()}, torch::kFloat32);
  // clone() copies out of the Mat's buffer (contiguous() alone would not for one-channel images).
  return hwc.permute({2, 0, 1}).clone(at::MemoryFormat::Contiguous);
}

double psnr(const cv::Mat& a, const cv::Mat& b) { return psnr(image_to_chw(a), image_to_chw(b)); }

double ssim(const cv::Mat& a, const cv::Mat& b) { return ssim(image_to_chw(a), image_to_chw(b)); }

}  // namespace lrf
