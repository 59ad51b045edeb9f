#include "lrf/detail/detail_blend.h"

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "lrf/core/error.h"

namespace lrf::detail {
namespace {

cv::Mat blurred(const cv::Mat& image, double sigma) {
  cv::Mat out;
  cv::GaussianBlur(image, out, cv::Size(0, 0), sigma, sigma, cv::BORDER_REFLECT);
  return out;
}

// The blur of a photograph's valid pixels only (normalised convolution), so that the zeros outside its
// footprint do not darken the colours at its edge.
cv::Mat blurred_where_valid(const cv::Mat& image, const cv::Mat& valid, double sigma) {
  cv::Mat weight = blurred(valid, sigma);
  cv::Mat sum = blurred(image, sigma);  // invalid pixels are 0 in WarpedView::image
  cv::Mat out(image.size(), CV_32FC3);
  for (int i = 0; i < image.rows; ++i) {
    const cv::Vec3f* s = sum.ptr<cv::Vec3f>(i);
    const float* w = weight.ptr<float>(i);
    cv::Vec3f* o = out.ptr<cv::Vec3f>(i);
    for (int j = 0; j < image.cols; ++j) o[j] = w[j] > 1e-3f ? s[j] / w[j] : cv::Vec3f(0, 0, 0);
  }
  return out;
}

// Per pixel, how far the photographs agree with one another: exp(-(s / scale)^2) with s the standard deviation
// of their colours (mean over channels, over a 5x5 window). Where geometry puts them on the same surface
// point they agree to the noise; where it does not, they disagree and the decoded view should stay.
cv::Mat mutual_agreement(const std::vector<WarpedView>& warped, double scale, cv::Size size) {
  cv::Mat pairs;
  cv::Mat variance = colour_variance(warped, size, &pairs);
  cv::boxFilter(variance, variance, CV_32F, cv::Size(5, 5), cv::Point(-1, -1), false, cv::BORDER_REFLECT);
  cv::boxFilter(pairs, pairs, CV_32F, cv::Size(5, 5), cv::Point(-1, -1), false, cv::BORDER_REFLECT);
  cv::Mat out(size, CV_32F, cv::Scalar(1));
  const float inv = static_cast<float>(1.0 / (scale * scale));
  for (int i = 0; i < size.height; ++i) {
    const float* v = variance.ptr<float>(i);
    const float* p = pairs.ptr<float>(i);
    float* o = out.ptr<float>(i);
    // A pixel seen by one photograph only has nothing to check it against: its trust is left to agreement.
    for (int j = 0; j < size.width; ++j) o[j] = p[j] > 0 ? std::exp(-v[j] / p[j] * inv) : 1.0f;
  }
  return out;
}

}  // namespace

std::vector<cv::Mat> photograph_trusts(const cv::Mat& decoded, const std::vector<WarpedView>& warped,
                                       const DetailOptions& options) {
  if (decoded.type() != CV_32FC3) fail("blend_detail: the decoded view must be float RGB");
  for (const auto& w : warped) {
    if (w.image.size() != decoded.size() || w.valid.size() != decoded.size())
      fail("blend_detail: a warped view's size differs from the decoded view's");
  }
  const cv::Mat decoded_low = blurred(decoded, options.blur_sigma);
  const float inv_agreement = static_cast<float>(1.0 / options.agreement);
  const cv::Mat mutual = options.consistency > 0 ? mutual_agreement(warped, options.consistency, decoded.size())
                                                 : cv::Mat(decoded.size(), CV_32F, cv::Scalar(1));
  std::vector<cv::Mat> trusts;
  for (const auto& w : warped) {
    const cv::Mat low = blurred_where_valid(w.image, w.valid, options.blur_sigma);
    cv::Mat trust(decoded.size(), CV_32F, cv::Scalar(0));
    for (int i = 0; i < decoded.rows; ++i) {
      const cv::Vec3f* dl = decoded_low.ptr<cv::Vec3f>(i);
      const cv::Vec3f* cl = low.ptr<cv::Vec3f>(i);
      const float* v = w.valid.ptr<float>(i);
      const float* agree = mutual.ptr<float>(i);
      float* t = trust.ptr<float>(i);
      for (int j = 0; j < decoded.cols; ++j) {
        if (v[j] <= 0) continue;
        const cv::Vec3f gap = cl[j] - dl[j];
        const float e = (std::abs(gap[0]) + std::abs(gap[1]) + std::abs(gap[2])) / 3.0f * inv_agreement;
        t[j] = v[j] * agree[j] * std::exp(-e * e);
      }
    }
    trusts.push_back(trust);
  }
  return trusts;
}

cv::Mat blend_detail(const cv::Mat& decoded, const std::vector<WarpedView>& warped, const DetailOptions& options) {
  return blend_with_trusts(decoded, warped, photograph_trusts(decoded, warped, options), options);
}

cv::Mat blend_with_trusts(const cv::Mat& decoded, const std::vector<WarpedView>& warped,
                          const std::vector<cv::Mat>& trusts, const DetailOptions& options) {
  if (trusts.size() != warped.size()) fail("blend_detail: one trust map per warped view is needed");
  const float own = static_cast<float>(options.decoded_weight);
  const cv::Mat decoded_low = options.high_frequencies_only ? blurred(decoded, options.blur_sigma) : cv::Mat();
  cv::Mat sum(decoded.size(), CV_32FC3, cv::Scalar::all(0));
  cv::Mat weight(decoded.size(), CV_32F, cv::Scalar(0));
  for (size_t k = 0; k < warped.size(); ++k) {
    const WarpedView& w = warped[k];
    const cv::Mat low = options.high_frequencies_only ? blurred_where_valid(w.image, w.valid, options.blur_sigma) : cv::Mat();
    for (int i = 0; i < decoded.rows; ++i) {
      const cv::Vec3f* d = decoded.ptr<cv::Vec3f>(i);
      const cv::Vec3f* c = w.image.ptr<cv::Vec3f>(i);
      const float* t = trusts[k].ptr<float>(i);
      cv::Vec3f* s = sum.ptr<cv::Vec3f>(i);
      float* ws = weight.ptr<float>(i);
      for (int j = 0; j < decoded.cols; ++j) {
        if (t[j] <= 0) continue;
        // A photograph proposes its colour, or the decoded view with the photograph's detail in place of its own.
        const cv::Vec3f proposal =
            options.high_frequencies_only
                ? d[j] + (c[j] - low.ptr<cv::Vec3f>(i)[j]) - (d[j] - decoded_low.ptr<cv::Vec3f>(i)[j])
                : c[j];
        s[j] += t[j] * proposal;
        ws[j] += t[j];
      }
    }
  }
  cv::Mat out(decoded.size(), CV_32FC3);
  for (int i = 0; i < decoded.rows; ++i) {
    const cv::Vec3f* d = decoded.ptr<cv::Vec3f>(i);
    const cv::Vec3f* s = sum.ptr<cv::Vec3f>(i);
    const float* ws = weight.ptr<float>(i);
    cv::Vec3f* o = out.ptr<cv::Vec3f>(i);
    for (int j = 0; j < decoded.cols; ++j) {
      const cv::Vec3f v = (own * d[j] + s[j]) / (own + ws[j]);
      for (int c = 0; c < 3; ++c) o[j][c] = std::min(1.0f, std::max(0.0f, v[c]));
    }
  }
  return out;
}

}  // namespace lrf::detail
