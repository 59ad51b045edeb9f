#pragma once
// How a decoded view takes what the warped training photographs hold: per pixel, each photograph is
// trusted as far as its warp is valid and its blurred colours agree with the decoded view's blurred
// colours (where they disagree the field's geometry put the pixel in the wrong place), and the trusted
// photographs are averaged with the decoded view, which keeps a weight of its own.
#include <vector>

#include <opencv2/core.hpp>

#include "lrf/detail/view_warp.h"

namespace lrf::detail {

// The defaults were chosen on validation splits of fern, flower and room (their training views less every
// 8th, held out), never on their test views: docs/detail.md.
struct DetailOptions {
  int views = 3;                      // training photographs borrowed per frame
  double occlusion_tolerance = 0.05;  // fraction of the depth a point may lie behind the source's surface
  double blur_sigma = 2.0;            // pixels: the scale at which agreement is judged
  double agreement = 0.16;            // colour difference (0..1) at which a photograph's trust falls to 1/e
  double decoded_weight = 0.25;       // the decoded view's own weight beside each trusted photograph's 1
                                      //   (with calibration_views > 0, chosen per field instead)
  int calibration_views = 4;          // training views on which decoded_weight is chosen per field
                                      //   (detail_calibration.h); 0 = take decoded_weight as given
  bool learned_blend = false;         // learn the blend per field on its training views (blend_network.h)
  int learning_views = 16;            // training views it learns and is judged on (each rebuilt from the others)
  int learning_steps = 400;           // its Adam steps
  bool high_frequencies_only = false; // add only each photograph's detail above blur_sigma (else its colour)
  double consistency = 0.06;          // photographs' spread (std over a 5x5 window) at which every photograph's
                                      //   trust at a pixel falls to 1/e (0 = not used)
  double sweep_range = 0.2;           // depth_sweep.h: relative depth offsets tried around the field's (0 = off)
  int sweep_steps = 17;               // offsets tried
  int sweep_window = 5;               // pixels: the window over which the photographs must agree
};

// Each photograph's trust per pixel (CV_32F, 0..1): its validity x the photographs' mutual agreement x its
// blurred colours' agreement with the decoded view's. `decoded` is CV_32FC3 in [0, 1]; every warped view has
// its size (else lrf::Error).
std::vector<cv::Mat> photograph_trusts(const cv::Mat& decoded, const std::vector<WarpedView>& warped,
                                       const DetailOptions& options);

// The decoded view and the photographs averaged with those trusts, the decoded view at its own weight.
// Returns CV_32FC3 clamped to [0, 1].
cv::Mat blend_detail(const cv::Mat& decoded, const std::vector<WarpedView>& warped, const DetailOptions& options);
// The same with the trusts given (photograph_trusts' result, which does not depend on the decoded weight),
// for callers that blend one view at several weights.
cv::Mat blend_with_trusts(const cv::Mat& decoded, const std::vector<WarpedView>& warped,
                          const std::vector<cv::Mat>& trusts, const DetailOptions& options);

}  // namespace lrf::detail
