// The detail pass's parts against what they must do on scenes whose geometry is known exactly: a textured
// plane seen by two pinhole cameras.
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "lrf/core/error.h"
#include "lrf/detail/blend_network.h"
#include "lrf/detail/depth_sweep.h"
#include "lrf/detail/detail_blend.h"
#include "lrf/detail/detail_calibration.h"
#include "lrf/detail/source_views.h"
#include "lrf/detail/view_warp.h"

namespace {

using lrf::Camera;

Camera camera_at(double x, int width = 64, int height = 48) {
  Camera c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = 60;
  c.cx = width / 2.0;
  c.cy = height / 2.0;
  c.t = Eigen::Vector3d(-x, 0, 0);  // centre at (x, 0, 0), looking down +z
  return c;
}

// A texture on the plane z = plane_z, `sharpness` times as fine as the smooth one (smooth: bilinear sampling
// is exact to ~1e-3).
cv::Vec3f texture(double X, double Y, double sharpness) {
  const double k = sharpness;
  return cv::Vec3f(static_cast<float>(0.5 + 0.4 * std::sin(3 * k * X)), static_cast<float>(0.5 + 0.4 * std::cos(2 * k * Y)),
                   static_cast<float>(0.5 + 0.2 * std::sin(k * (X + Y))));
}

// What `camera` sees of the plane: its image and depth map.
void view_of_plane(const Camera& camera, double plane_z, cv::Mat* image, cv::Mat* depth, double sharpness = 1) {
  *image = cv::Mat(camera.height, camera.width, CV_32FC3);
  *depth = cv::Mat(camera.height, camera.width, CV_32F, cv::Scalar(static_cast<float>(plane_z)));
  const Eigen::Vector3d centre = camera.center();
  for (int i = 0; i < camera.height; ++i)
    for (int j = 0; j < camera.width; ++j) {
      const double X = centre.x() + (j + 0.5 - camera.cx) / camera.fx * plane_z;
      const double Y = centre.y() + (i + 0.5 - camera.cy) / camera.fy * plane_z;
      image->at<cv::Vec3f>(i, j) = texture(X, Y, sharpness);
    }
}

TEST(DetailWarp, CarriesAPlaneIntoAnotherCameraWhereItIsSeen) {
  const Camera source = camera_at(0.0), target = camera_at(0.3);
  cv::Mat source_image, source_depth, truth, target_depth;
  view_of_plane(source, 2.0, &source_image, &source_depth);
  view_of_plane(target, 2.0, &truth, &target_depth);
  const auto warped = lrf::detail::warp_view(source_image, source_depth, source, target_depth, target, 0.02);
  // The target sits 0.3 to the right at depth 2: its right 0.3 * 60 / 2 = 9 columns are outside the source.
  int valid = 0;
  double worst = 0;
  for (int i = 0; i < target.height; ++i)
    for (int j = 0; j < target.width; ++j) {
      const bool inside = j + 0.5 + 9 <= source.width - 0.5 && j + 0.5 + 9 >= 0.5;
      const bool seen = warped.valid.at<float>(i, j) > 0;
      if (i > 0 && i < target.height - 1) {
        EXPECT_EQ(seen, inside) << i << "," << j;
      }
      if (!seen) continue;
      ++valid;
      const cv::Vec3f d = warped.image.at<cv::Vec3f>(i, j) - truth.at<cv::Vec3f>(i, j);
      worst = std::max(worst, static_cast<double>(std::max({std::abs(d[0]), std::abs(d[1]), std::abs(d[2])})));
    }
  EXPECT_GT(valid, 40 * 46);
  // Bilinear interpolation of a texture whose second derivative is at most 0.4 * 9 / 30^2 per pixel^2.
  EXPECT_LT(worst, 2e-3);
}

TEST(DetailWarp, ANearerSurfaceInTheSourceHidesThePoint) {
  const Camera source = camera_at(0.0), target = camera_at(0.3);
  cv::Mat source_image, source_depth, truth, target_depth;
  view_of_plane(source, 2.0, &source_image, &source_depth);
  view_of_plane(target, 2.0, &truth, &target_depth);
  source_depth.setTo(cv::Scalar(1.9f));  // the source sees something 5 % nearer everywhere
  auto warped = lrf::detail::warp_view(source_image, source_depth, source, target_depth, target, 0.02);
  EXPECT_EQ(cv::countNonZero(warped.valid), 0);
  warped = lrf::detail::warp_view(source_image, source_depth, source, target_depth, target, 0.06);
  EXPECT_GT(cv::countNonZero(warped.valid), 40 * 46);
  target_depth.setTo(cv::Scalar(0.0f));  // no surface in the target: nothing to carry
  warped = lrf::detail::warp_view(source_image, source_depth, source, target_depth, target, 0.06);
  EXPECT_EQ(cv::countNonZero(warped.valid), 0);
}

TEST(DetailWarp, RefusesMapsOfTheWrongSize) {
  const Camera c = camera_at(0.0);
  cv::Mat image(c.height, c.width, CV_32FC3, cv::Scalar::all(0)), depth(c.height, c.width, CV_32F, cv::Scalar(1));
  cv::Mat small(10, 10, CV_32F, cv::Scalar(1));
  EXPECT_THROW(lrf::detail::warp_view(image, small, c, depth, c, 0.02), std::exception);
  EXPECT_THROW(lrf::detail::warp_view(image, depth, c, small, c, 0.02), std::exception);
}

TEST(DetailBlend, TrustsAgreeingPhotographsAndIgnoresDisagreeingOnes) {
  const Camera c = camera_at(0.0);
  cv::Mat truth, depth;
  view_of_plane(c, 2.0, &truth, &depth);
  cv::Mat decoded;
  cv::GaussianBlur(truth, decoded, cv::Size(0, 0), 3.0);  // the decoded view: right colours, no detail
  lrf::detail::DetailOptions o;
  o.decoded_weight = 0.25;
  o.agreement = 0.05;
  cv::Mat ones(c.height, c.width, CV_32F, cv::Scalar(1));
  // One photograph that is the truth: the result is (0.25 decoded + ~1 truth) / ~1.25 per pixel.
  cv::Mat out = lrf::detail::blend_detail(decoded, {{truth.clone(), ones}}, o);
  const double before = cv::norm(decoded, truth, cv::NORM_L2), after = cv::norm(out, truth, cv::NORM_L2);
  EXPECT_LT(after, 0.3 * before);
  // A photograph of something else (colours off by 0.3): trusted at exp(-36) ~ 0, the decoded view stays.
  cv::Mat wrong = truth + cv::Scalar::all(0.3);
  out = lrf::detail::blend_detail(decoded, {{wrong, ones}}, o);
  EXPECT_LT(cv::norm(out, decoded, cv::NORM_INF), 1e-4);
  // Nothing valid: the decoded view unchanged.
  out = lrf::detail::blend_detail(decoded, {{truth.clone(), cv::Mat::zeros(c.height, c.width, CV_32F)}}, o);
  EXPECT_LT(cv::norm(out, decoded, cv::NORM_INF), 1e-6);
}

TEST(DetailSweep, FindsThePlaneFromAWrongDepth) {
  const Camera target = camera_at(0.15);
  std::vector<Camera> cameras = {camera_at(0.0), camera_at(0.3)};
  std::vector<cv::Mat> images(2), depths(2);
  std::vector<lrf::detail::SweepSource> sources;
  for (int k = 0; k < 2; ++k) {
    // Detail of a few pixels' period, as the pass is for: a 5 % depth error shifts it by 0.2 pixels.
    view_of_plane(cameras[k], 2.0, &images[k], &depths[k], 8.0);
    sources.push_back({&images[k], &depths[k], &cameras[k]});
  }
  // The field says 2.1: 5 % too far. A sweep of ±10 % in 21 steps (1 % apart) must land on 2.0.
  cv::Mat wrong(target.height, target.width, CV_32F, cv::Scalar(2.1f));
  lrf::detail::DepthSweepOptions o;
  o.range = 0.1;
  o.steps = 21;
  o.occlusion_tolerance = 0.1;
  const cv::Mat found = lrf::detail::sweep_depth(wrong, target, sources, o);
  int right = 0, seen = 0;
  for (int i = 0; i < target.height; ++i)
    for (int j = 10; j < target.width - 10; ++j) {  // columns both sources see
      ++seen;
      if (std::abs(found.at<float>(i, j) - 2.0f) < 2.1f * 0.011f) ++right;
    }
  EXPECT_GT(right, 0.95 * seen);
  o.range = 0;  // off: the depth as given
  EXPECT_EQ(cv::norm(lrf::detail::sweep_depth(wrong, target, sources, o), wrong, cv::NORM_INF), 0);
}

// The decoded weight follows the decoder: a blurring decoder beside true photographs takes them almost
// wholly (the lowest weight), a decoder that already returns the photograph beside slightly wrong ones
// keeps its frame alone. Every candidate is scored, in order, and the scores are PSNRs of what was blended.
TEST(DetailCalibration, ChoosesThePhotographsForABlurryDecoderAndNoneForASharpOne) {
  const Camera c = camera_at(0.0);
  cv::Mat truth, depth;
  view_of_plane(c, 2.0, &truth, &depth, 4.0);
  cv::Mat blurry;
  cv::GaussianBlur(truth, blurry, cv::Size(0, 0), 3.0);
  const cv::Mat ones(c.height, c.width, CV_32F, cv::Scalar(1));
  lrf::detail::DetailOptions o;
  o.consistency = 0;
  const auto weights = lrf::detail::calibration_weights();

  const auto blurry_decoder = lrf::detail::calibrate_decoded_weight({{truth, blurry, {{truth.clone(), ones}}}}, o);
  EXPECT_EQ(blurry_decoder.decoded_weight, weights.front());
  ASSERT_EQ(blurry_decoder.scores.size(), weights.size());
  // The last candidate is the decoded frame alone: its score is the blurry frame's own PSNR.
  const double blurry_mse = std::pow(cv::norm(blurry, truth, cv::NORM_L2), 2) / (truth.total() * 3.0);
  EXPECT_NEAR(blurry_decoder.scores.back().psnr, -10 * std::log10(blurry_mse), 1e-9);
  EXPECT_GT(blurry_decoder.scores.front().psnr, blurry_decoder.scores.back().psnr + 3);

  // The photograph borrowed is the truth shifted by one pixel: close enough in colour to be trusted,
  // wrong in its detail, so every blend scores below the sharp frame.
  cv::Mat shifted;
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 1, 0, 1, 0);
  cv::warpAffine(truth, shifted, shift, truth.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  const auto sharp_decoder = lrf::detail::calibrate_decoded_weight({{truth, truth.clone(), {{shifted, ones}}}}, o);
  EXPECT_TRUE(std::isinf(sharp_decoder.decoded_weight));
  for (size_t k = 1; k < weights.size(); ++k) EXPECT_GT(sharp_decoder.scores[k].psnr, sharp_decoder.scores[k - 1].psnr);

  EXPECT_THROW(lrf::detail::calibrate_decoded_weight({}, o), lrf::Error);
}

// A training view standing in for a novel one never borrows from itself.
TEST(DetailSourceViews, ATrainingViewCanBeLeftOut) {
  lrf::Scene scene;
  for (const double x : {0.0, 0.1, 0.25, 0.45}) {
    lrf::View v;
    v.camera = camera_at(x);
    scene.views.push_back(v);
    scene.train_indices.push_back(static_cast<int>(scene.train_indices.size()));
  }
  EXPECT_EQ(lrf::detail::nearest_training_views(scene, camera_at(0.1), 2), (std::vector<int>{1, 0}));
  EXPECT_EQ(lrf::detail::nearest_training_views(scene, camera_at(0.1), 2, 1), (std::vector<int>{0, 2}));
}

// The learned blend starts as the hand-made one, and learns what the hand-made one cannot see: here the
// first photograph is always shifted by a pixel (its colours agree at the blur's scale, so the hand-made
// blend trusts it) and the second is always right. On training views it did not learn on, the learned
// blend must come out well ahead, and its frames must be the ones it scored.
TEST(DetailBlendNetwork, StartsAsTheHandMadeBlendAndLearnsWhichPhotographToTrust) {
  std::vector<lrf::detail::CalibrationSample> samples;
  const cv::Mat ones(48, 64, CV_32F, cv::Scalar(1));
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 1, 0, 1, 0);
  for (int k = 0; k < 8; ++k) {
    cv::Mat truth, depth, blurry, shifted;
    view_of_plane(camera_at(0.37 * k), 2.0 + 0.1 * k, &truth, &depth, 4.0);
    cv::GaussianBlur(truth, blurry, cv::Size(0, 0), 2.0);
    cv::warpAffine(truth, shifted, shift, truth.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
    samples.push_back({truth, blurry, {{shifted, ones}, {truth.clone(), ones}}});
  }
  lrf::detail::DetailOptions o;
  o.views = 2;
  o.consistency = 0;
  o.decoded_weight = 0.25;

  lrf::detail::BlendNetworkOptions untrained;
  untrained.steps = 0;
  lrf::detail::BlendNetworkReport r;
  lrf::detail::BlendNetwork::learn(samples, o, untrained, &r);
  EXPECT_EQ(r.learned_on, 6);
  EXPECT_EQ(r.held_out, 2);
  // The same blend up to the 1e-6 floor under the trusts' logarithms.
  EXPECT_NEAR(r.learned_psnr, r.handmade_psnr, 0.01);

  lrf::detail::BlendNetworkOptions n;
  n.steps = 150;
  n.crop = 32;
  const auto network = lrf::detail::BlendNetwork::learn(samples, o, n, &r);
  ASSERT_TRUE(network) << r.learned_psnr << " vs " << r.handmade_psnr;
  EXPECT_TRUE(r.used);
  EXPECT_GT(r.learned_psnr, r.handmade_psnr + 2.0) << r.handmade_psnr;
  // Its frame of a held-out view beats the hand-made frame.
  const auto& s = samples[3];
  const cv::Mat learned = network->blend(s.decoded, s.warped), handmade = lrf::detail::blend_detail(s.decoded, s.warped, o);
  EXPECT_LT(cv::norm(learned, s.photo, cv::NORM_L2), 0.8 * cv::norm(handmade, s.photo, cv::NORM_L2));

  // Too few views to hold any out: nothing is learned.
  EXPECT_FALSE(lrf::detail::BlendNetwork::learn({samples[0], samples[1], samples[2]}, o, n, &r));
  EXPECT_FALSE(r.used);
}

}  // namespace
