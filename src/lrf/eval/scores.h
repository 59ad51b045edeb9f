#pragma once
// Scoring of rendered test views against their ground truth, and the per-scene means that the paper's
// tables report.
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "lrf/eval/lpips.h"

namespace lrf {

struct ImageScores {
  double psnr = 0.0;
  double ssim = 0.0;
  double flip = 0.0;               // lower is better
  std::optional<double> ms_ssim;   // absent for images too small for its five scales
  std::optional<double> lpips;     // absent when no LPIPS weights were given
};

// PSNR, SSIM, MS-SSIM, FLIP and (if `lpips` is given) LPIPS of `render` against `truth`: RGB images of the same size,
// float in [0, 1] or 8-bit. `name` (e.g. the view's file) is named in errors.
ImageScores score_image(const cv::Mat& truth, const cv::Mat& render, const Lpips* lpips = nullptr,
                        const std::string& name = "");
// The same for [C, H, W] float images in [0, 1] (clamped).
ImageScores score_image(const torch::Tensor& truth, const torch::Tensor& render, const Lpips* lpips = nullptr,
                        const std::string& name = "");
// The mean of per-image scores, as 3DGS averages them (the mean of per-image PSNRs, not the PSNR of
// the mean error). MS-SSIM and LPIPS are set only if every image has them. Throws lrf::Error for an empty list.
ImageScores mean_scores(const std::vector<ImageScores>& scores);
// {"psnr": .., "ssim": .., "ms_ssim": value or null, "flip": .., "lpips": value or null}
nlohmann::json scores_json(const ImageScores& scores);

}  // namespace lrf
