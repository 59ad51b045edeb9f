#include "lrf/eval/metrics.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "lrf/core/error.h"
#include "lrf/eval/ssim_terms.h"

namespace lrf {
namespace {

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

torch::Tensor clamped64(const torch::Tensor& t, double max) {
  return t.to(torch::kCPU, torch::kFloat64).clamp(0.0, max);
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
  const int h = static_cast<int>(x.size(1)), w = static_cast<int>(x.size(2));
  double sum = 0.0;  // every channel has h·w pixels, so the mean of channel means is the mean of the map
  for (int c = 0; c < x.size(0); ++c) {
    const cv::Mat xc(h, w, CV_64F, x[c].data_ptr<double>()), yc(h, w, CV_64F, y[c].data_ptr<double>());
    const SsimTerms t = ssim_terms(xc, yc, c1, c2, SsimWindowPlacement::kSameZeroPadded);
    sum += cv::mean(t.luminance.mul(t.contrast_structure))[0];
  }
  return sum / double(x.size(0));
}

double psnr_from_mse(double mse_value, double peak) {
  if (!(mse_value > 0.0)) return kPsnrCapDb;
  return std::min(kPsnrCapDb, 10.0 * std::log10(peak * peak / mse_value));
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
