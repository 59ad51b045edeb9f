#include "lrf/eval/scores.h"

#include "lrf/core/error.h"
#include "lrf/eval/flip.h"
#include "lrf/eval/metrics.h"
#include "lrf/eval/ms_ssim.h"

namespace lrf {

ImageScores score_image(const cv::Mat& truth, const cv::Mat& render, const Lpips* lpips, const std::string& name) {
  if (truth.size() != render.size() || truth.channels() != render.channels()) {
    fail(name, "render is " + std::to_string(render.cols) + "x" + std::to_string(render.rows) + "x" +
                   std::to_string(render.channels()) + " but the ground truth is " + std::to_string(truth.cols) +
                   "x" + std::to_string(truth.rows) + "x" + std::to_string(truth.channels()));
  }
  return score_image(image_to_chw(truth), image_to_chw(render), lpips, name);
}

ImageScores score_image(const torch::Tensor& truth, const torch::Tensor& render, const Lpips* lpips,
                        const std::string& name) {
  try {
    ImageScores s;
    s.psnr = psnr(truth, render);
    s.ssim = ssim(truth, render);
    s.ms_ssim = ms_ssim(truth, render);
    // FLIP is defined on colour; a grey image is the colour image with three equal channels.
    auto colour = [](const torch::Tensor& x) { return x.dim() == 3 && x.size(0) == 1 ? x.expand({3, -1, -1}) : x; };
    s.flip = flip(colour(truth), colour(render));
    if (lpips) s.lpips = lpips->distance(truth, render);
    return s;
  } catch (const Error& e) {
    if (name.empty()) throw;
    fail(name, e.what());
  }
}

namespace {

// The mean of an optional score, present only if every image has it.
std::optional<double> mean_if_all(const std::vector<ImageScores>& scores, std::optional<double> ImageScores::*score) {
  double sum = 0.0;
  for (const auto& s : scores) {
    if (!(s.*score)) return std::nullopt;
    sum += *(s.*score);
  }
  return sum / static_cast<double>(scores.size());
}

nlohmann::json optional_json(const std::optional<double>& v) { return v ? nlohmann::json(*v) : nlohmann::json(nullptr); }

}  // namespace

ImageScores mean_scores(const std::vector<ImageScores>& scores) {
  if (scores.empty()) fail("no test views to average");
  ImageScores mean;
  for (const auto& s : scores) {
    mean.psnr += s.psnr;
    mean.ssim += s.ssim;
    mean.flip += s.flip;
  }
  const double n = static_cast<double>(scores.size());
  mean.psnr /= n;
  mean.ssim /= n;
  mean.flip /= n;
  mean.ms_ssim = mean_if_all(scores, &ImageScores::ms_ssim);
  mean.lpips = mean_if_all(scores, &ImageScores::lpips);
  return mean;
}

nlohmann::json scores_json(const ImageScores& s) {
  return {{"psnr", s.psnr},
          {"ssim", s.ssim},
          {"ms_ssim", optional_json(s.ms_ssim)},
          {"flip", s.flip},
          {"lpips", optional_json(s.lpips)}};
}

}  // namespace lrf
