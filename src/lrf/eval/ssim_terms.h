#pragma once
// The two factors of SSIM at every pixel, shared by SSIM (same-size maps, zero padding, as 3DGS scores) and
// MS-SSIM (only where the window lies wholly inside the image, as Wang et al. define it): the luminance term
// l = (2·μx·μy + C1) / (μx² + μy² + C1) and the contrast-structure term
// cs = (2·σxy + C2) / (σx² + σy² + C2), with local moments under an 11×11 Gaussian window of σ 1.5.
#include <opencv2/core.hpp>

namespace lrf {

enum class SsimWindowPlacement {
  kSameZeroPadded,  // one value per pixel; the window reads zeros outside the image
  kValid,           // (H - 10) × (W - 10) values; the window never leaves the image
};

struct SsimTerms {
  cv::Mat luminance;           // CV_64F
  cv::Mat contrast_structure;  // CV_64F
};

// x and y: single-channel CV_64F images of the same size.
SsimTerms ssim_terms(const cv::Mat& x, const cv::Mat& y, double c1, double c2, SsimWindowPlacement placement);

}  // namespace lrf
