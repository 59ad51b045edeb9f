#include "lrf/detail/detail_calibration.h"

#include <cmath>

#include "lrf/core/error.h"
#include "lrf/eval/metrics.h"

namespace lrf::detail {

const std::vector<double>& calibration_weights() {
  static const std::vector<double> weights = {0.25, 0.5, 1.0, 2.0, 4.0, 8.0, std::numeric_limits<double>::infinity()};
  return weights;
}

DetailCalibration calibrate_decoded_weight(const std::vector<CalibrationSample>& samples, const DetailOptions& options) {
  if (samples.empty()) fail("calibrate_decoded_weight: no training views to calibrate on");
  for (const auto& s : samples) {
    if (s.photo.type() != CV_32FC3 || s.decoded.type() != CV_32FC3 || s.photo.size() != s.decoded.size())
      fail("calibrate_decoded_weight: a sample's photograph and decoded frame differ in size or type");
  }
  // The trusts do not depend on the weight: made once per view, not once per candidate.
  std::vector<std::vector<cv::Mat>> trusts;
  for (const auto& s : samples) trusts.push_back(photograph_trusts(s.decoded, s.warped, options));
  DetailCalibration result;
  double best_error = std::numeric_limits<double>::infinity();
  for (const double weight : calibration_weights()) {
    double squared = 0, values = 0;
    for (size_t i = 0; i < samples.size(); ++i) {
      const CalibrationSample& s = samples[i];
      cv::Mat frame = s.decoded;
      if (std::isfinite(weight)) {
        DetailOptions o = options;
        o.decoded_weight = weight;
        frame = blend_with_trusts(s.decoded, s.warped, trusts[i], o);
      }
      const double norm = cv::norm(frame, s.photo, cv::NORM_L2);
      squared += norm * norm;
      values += static_cast<double>(s.photo.total()) * 3;
    }
    const double mse = squared / values;
    result.scores.push_back({weight, psnr_from_mse(mse)});
    // Strictly lower: on a tie the candidate tried first, taking more from the photographs, keeps the lead.
    if (mse < best_error) best_error = mse, result.decoded_weight = weight;
  }
  return result;
}

}  // namespace lrf::detail
