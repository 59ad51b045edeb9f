#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "lrf/core/error.h"
#include "lrf/eval/metrics.h"
#include "lrf/eval/scores.h"

TEST(EvalScores, ScoresAViewAndAveragesPerImage) {
  cv::Mat truth(32, 32, CV_32FC3, cv::Scalar(0.5, 0.5, 0.5));
  cv::Mat off1 = truth + cv::Scalar(0.1, 0.1, 0.1);   // MSE 0.01   → 20 dB
  cv::Mat off2 = truth + cv::Scalar(0.01, 0.01, 0.01);  // MSE 0.0001 → 40 dB
  auto a = lrf::score_image(truth, off1);
  auto b = lrf::score_image(truth, off2);
  // float32 images: the offsets carry ~1e-8 rounding, far below 1e-4 dB.
  EXPECT_NEAR(a.psnr, 20.0, 1e-4);
  EXPECT_NEAR(b.psnr, 40.0, 1e-4);
  EXPECT_FALSE(a.lpips.has_value());
  // 32x32 is too small for MS-SSIM's five scales; FLIP of a uniform grey shift is above zero.
  EXPECT_FALSE(a.ms_ssim.has_value());
  EXPECT_GT(a.flip, b.flip);
  EXPECT_GT(b.flip, 0.0);
  auto mean = lrf::mean_scores({a, b});
  // The mean of per-image PSNRs (30 dB), not the PSNR of the mean MSE (≈ 22.97 dB).
  EXPECT_NEAR(mean.psnr, 30.0, 1e-4);
  EXPECT_NEAR(mean.ssim, (a.ssim + b.ssim) / 2, 1e-12);
  auto json = lrf::scores_json(mean);
  EXPECT_TRUE(json["lpips"].is_null());
  EXPECT_NEAR(json["psnr"].get<double>(), 30.0, 1e-4);
  EXPECT_TRUE(json["ms_ssim"].is_null());
  EXPECT_NEAR(json["flip"].get<double>(), (a.flip + b.flip) / 2, 1e-12);
  // LPIPS is averaged only when every view has it.
  a.lpips = 0.2;
  EXPECT_FALSE(lrf::mean_scores({a, b}).lpips.has_value());
  b.lpips = 0.4;
  EXPECT_NEAR(*lrf::mean_scores({a, b}).lpips, 0.3, 1e-12);
  EXPECT_THROW(lrf::mean_scores({}), lrf::Error);
}

TEST(EvalScores, SizeMismatchNamesTheView) {
  cv::Mat truth(32, 32, CV_32FC3, cv::Scalar::all(0.5));
  cv::Mat render(32, 24, CV_32FC3, cv::Scalar::all(0.5));
  try {
    lrf::score_image(truth, render, nullptr, "images/IMG_0001.JPG");
    FAIL() << "expected an error";
  } catch (const lrf::Error& e) {
    EXPECT_NE(std::string(e.what()).find("images/IMG_0001.JPG: render is 24x32x3"), std::string::npos) << e.what();
  }
}
