#include "lrf/eval/ms_ssim.h"

#include <array>
#include <cmath>
#include <sstream>

#include <opencv2/core.hpp>

#include "lrf/core/error.h"
#include "lrf/eval/ssim_terms.h"

namespace lrf {
namespace {

constexpr std::array<double, 5> kWeights = {0.0448, 0.2856, 0.3001, 0.2363, 0.1333};

// 2x2 average pooling; an odd last row or column is dropped.
cv::Mat halve(const cv::Mat& x) {
  cv::Mat out(x.rows / 2, x.cols / 2, CV_64F);
  for (int i = 0; i < out.rows; ++i) {
    const double* a = x.ptr<double>(2 * i);
    const double* b = x.ptr<double>(2 * i + 1);
    double* o = out.ptr<double>(i);
    for (int j = 0; j < out.cols; ++j) o[j] = 0.25 * (a[2 * j] + a[2 * j + 1] + b[2 * j] + b[2 * j + 1]);
  }
  return out;
}

}  // namespace

std::optional<double> ms_ssim(const torch::Tensor& a, const torch::Tensor& b, double max) {
  if (!a.defined() || !b.defined() || a.dim() != 3 || a.sizes() != b.sizes() || a.numel() == 0) {
    std::ostringstream s;
    s << "ms_ssim: expected two [C, H, W] images of the same size, got "
      << (a.defined() ? a.sizes() : c10::IntArrayRef{}) << " and " << (b.defined() ? b.sizes() : c10::IntArrayRef{});
    fail(s.str());
  }
  if (!(max > 0.0)) fail("ms_ssim: max value must be positive");
  if (a.size(1) < kMsSsimMinSide || a.size(2) < kMsSsimMinSide) return std::nullopt;
  torch::NoGradGuard no_grad;
  auto x = a.to(torch::kCPU, torch::kFloat64).clamp(0.0, max).contiguous();
  auto y = b.to(torch::kCPU, torch::kFloat64).clamp(0.0, max).contiguous();
  const int channels = static_cast<int>(x.size(0)), h = static_cast<int>(x.size(1)), w = static_cast<int>(x.size(2));
  const double c1 = (0.01 * max) * (0.01 * max), c2 = (0.03 * max) * (0.03 * max);
  double sum = 0.0;
  for (int c = 0; c < channels; ++c) {
    cv::Mat xc = cv::Mat(h, w, CV_64F, x[c].data_ptr<double>()).clone();
    cv::Mat yc = cv::Mat(h, w, CV_64F, y[c].data_ptr<double>()).clone();
    double value = 1.0;
    for (size_t scale = 0; scale < kWeights.size(); ++scale) {
      const SsimTerms t = ssim_terms(xc, yc, c1, c2, SsimWindowPlacement::kValid);
      value *= std::pow(std::max(0.0, cv::mean(t.contrast_structure)[0]), kWeights[scale]);
      if (scale + 1 == kWeights.size()) {
        value *= std::pow(std::max(0.0, cv::mean(t.luminance)[0]), kWeights[scale]);
      } else {
        xc = halve(xc);
        yc = halve(yc);
      }
    }
    sum += value;
  }
  return sum / channels;
}

}  // namespace lrf
