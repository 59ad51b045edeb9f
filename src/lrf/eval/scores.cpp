#include "lrf/eval/scores.h"

#include "lrf/core/error.h"
#include "lrf/eval/metrics.h"

namespace lrf {

ImageScores score_image(const cv::Mat& truth, const cv::Mat& render, const Lpips* lpips, const std::string& name) {
  if (truth.size() != render.size() || truth.channels() != render.channels()) {
    fail(name, "render is " + std::to_string(render.cols) + "x" + std::to_string(render.rows) + "x" +
                   std::to_string(render.channels()) + " but the ground truth is " + std::to_string(truth.cols) +
                   "x" + std::to_string(truth.rows) + "x" + std::to_string(truth.channels()));
  }
  try {
    auto t = image_to_chw(truth);
    auto r = image_to_chw(render);
    ImageScores s;
    s.psnr = psnr(t, r);
    s.ssim = ssim(t, r);
    if (lpips) s.lpips = lpips->distance(t, r);
    return s;
  } catch (const Error& e) {
    if (name.empty()) throw;
    fail(name, e.what());
  }
}

ImageScores mean_scores(const std::vector<ImageScores>& scores) {
  if (scores.empty()) fail("no test views to average");
  ImageScores mean;
  double lpips_sum = 0.0;
  bool all_lpips = true;
  for (const auto& s : scores) {
    mean.psnr += s.psnr;
    mean.ssim += s.ssim;
    all_lpips = all_lpips && s.lpips.has_value();
    if (s.lpips) lpips_sum += *s.lpips;
  }
  const double n = static_cast<double>(scores.size());
  mean.psnr /= n;
  mean.ssim /= n;
  if (all_lpips) mean.lpips = lpips_sum / n;
  return mean;
}

nlohmann::json scores_json(const ImageScores& s) {
  return {{"psnr", s.psnr}, {"ssim", s.ssim}, {"lpips", s.lpips ? nlohmann::json(*s.lpips) : nlohmann::json(nullptr)}};
}

}  // namespace lrf
