#pragma once
// A blend learned per scene on its own training views: each training view is rebuilt from its nearest other
// training photographs, and a small convolutional network learns, per pixel, how to weigh the decoded view
// against each carried photograph from what they look like around the pixel (their colours, validity and
// the hand-made trusts of detail_blend.h). It starts as the hand-made blend exactly (its last layer is zero,
// and it adds to the hand-made weights' logarithms) and is kept only when training views it never saw come
// out better than with the hand-made blend.
#include <cstdint>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "lrf/detail/detail_blend.h"
#include "lrf/detail/detail_calibration.h"

namespace lrf::detail {

struct BlendNetworkOptions {
  int steps = 400;     // Adam steps
  int crop = 96;       // pixels: the side of the crops it learns on
  int batch = 4;       // crops per step
  double lr = 2e-3;
  int width = 24;      // channels of its two hidden layers
  uint64_t seed = 0;
};

struct BlendNetworkReport {
  int learned_on = 0, held_out = 0;  // training views
  double handmade_psnr = 0;          // on the held-out views: the hand-made blend (or the decoded view alone)
  double learned_psnr = 0;           //   and the learned one
  double seconds = 0;
  bool used = false;                 // learned_psnr > handmade_psnr
};

class BlendNetwork {
 public:
  // Learns on `samples`, every fourth held out to judge it (at least 4 samples, else nothing is learned and
  // null returned). `options` is the hand-made blend it starts from, with its decoded weight already chosen
  // (infinity: the decoded view alone is the baseline). Returns null when it does not beat that baseline.
  static std::unique_ptr<BlendNetwork> learn(const std::vector<CalibrationSample>& samples, const DetailOptions& options,
                                             const BlendNetworkOptions& network, BlendNetworkReport* report);
  ~BlendNetwork();

  // `decoded` CV_32FC3 in [0, 1], up to `options.views` warped views of its size. Returns CV_32FC3 in [0, 1].
  cv::Mat blend(const cv::Mat& decoded, const std::vector<WarpedView>& warped) const;

 private:
  struct Impl;
  explicit BlendNetwork(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace lrf::detail
