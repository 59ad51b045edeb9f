#pragma once
// How much a field's frames should take from the photographs, chosen on the field's own training views.
// A decoder that already returns sharp images (TAEF2's 32 channels) loses by blending where one that blurs
// (VAElight's 4) gains, so no one decoded weight serves both. Each of a few training views stands in for a
// novel view: its frame is decoded, blended with its nearest *other* training photographs at each candidate
// weight, and scored against its own photograph. The weight with the lowest squared error over the views
// wins; taking no photographs at all is a candidate too.
#include <limits>
#include <vector>

#include <opencv2/core.hpp>

#include "lrf/detail/detail_blend.h"

namespace lrf::detail {

// One training view standing in for a novel one.
struct CalibrationSample {
  cv::Mat photo;                     // CV_32FC3, its own photograph
  cv::Mat decoded;                   // CV_32FC3, the field's frame for its camera
  std::vector<WarpedView> warped;    // its nearest other training photographs, carried into its camera
};

struct CalibrationScore {
  double decoded_weight;  // infinity: the decoded frame alone
  double psnr;            // over every sample's pixels together
};

struct DetailCalibration {
  double decoded_weight = std::numeric_limits<double>::infinity();  // the winner
  std::vector<CalibrationScore> scores;                             // every candidate, in the order tried
};

// The candidates: from mostly photographs to mostly decoded, then decoded alone.
const std::vector<double>& calibration_weights();

// Throws lrf::Error when `samples` is empty or a sample's images differ in size or type.
DetailCalibration calibrate_decoded_weight(const std::vector<CalibrationSample>& samples, const DetailOptions& options);

}  // namespace lrf::detail
