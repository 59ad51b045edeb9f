// Scene readers on the real scenes in ../shared/scenes: the figures the foundation issue asks for and
// geometry checks against COLMAP's own 2D observations.
#include <gtest/gtest.h>

#include "lrf/scene/reprojection.h"
#include "lrf/scene/scene.h"
#include "test_helpers.h"

namespace {

using lrf::test::scene_dir;

double median_reprojection_error(const lrf::Scene& s, size_t* count) {
  lrf::ReprojectionStats r = lrf::reprojection_error(s);
  *count = r.observations;
  EXPECT_EQ(r.behind_camera, 0u);
  return r.median_px;
}

TEST(SceneReal, FernLlffImages8) {
  lrf::SceneOptions o;
  o.images_dir = "images_8";
  lrf::Scene s = lrf::load_scene(scene_dir("llff-fern"), o);
  EXPECT_EQ(s.format, "llff");
  EXPECT_EQ(s.views.size(), 20u);
  EXPECT_EQ(s.train_indices.size(), 17u);
  EXPECT_EQ(s.test_indices, (std::vector<int>{0, 8, 16}));
  EXPECT_EQ(s.views[0].camera.width, 504);
  EXPECT_EQ(s.views[0].camera.height, 378);
  // 3260.526 (poses_bounds focal at 4032 px) x 504 / 4032.
  EXPECT_NEAR(s.views[0].camera.fx, 3260.5263328805895 * 504 / 4032, 1e-9);
  EXPECT_EQ(s.points.size(), 10091u);
  EXPECT_FALSE(s.has_tracks);
  cv::Mat img = s.load_image(3);
  EXPECT_EQ(img.cols, 504);
  EXPECT_EQ(img.rows, 378);
}

// The 3 views the few-shot LLFF literature trains fern on (test views 0, 8, 16; the 17 others at
// linspace(0, 16, 3)): image 1, 10 and 19.
TEST(SceneReal, FernThreeViewSplit) {
  lrf::SceneOptions o;
  o.images_dir = "images_8";
  o.train_views = 3;
  lrf::Scene s = lrf::load_scene(scene_dir("llff-fern"), o);
  EXPECT_EQ(s.train_indices, (std::vector<int>{1, 10, 19}));
  EXPECT_EQ(s.test_indices, (std::vector<int>{0, 8, 16}));
}

TEST(SceneReal, FernPointsProjectInsideWithLlffPoses) {
  lrf::SceneOptions o;
  o.images_dir = "images_8";
  lrf::Scene s = lrf::load_scene(scene_dir("llff-fern"), o);
  // Forward-facing capture: every view sees most of the reconstructed points. A wrong axis permutation
  // or sign puts them behind the camera or far outside the frame.
  for (const auto& v : s.views) {
    size_t inside = 0;
    for (const auto& p : s.points) {
      Eigen::Vector2d px;
      if (v.camera.project(p.xyz, &px) && px.x() >= 0 && px.y() >= 0 && px.x() < v.camera.width &&
          px.y() < v.camera.height) {
        ++inside;
      }
    }
    EXPECT_GT(inside, s.points.size() * 8 / 10) << v.name;
  }
}

TEST(SceneReal, BeerCanColmapReprojection) {
  lrf::Scene s = lrf::load_scene(scene_dir("beer-can"));
  EXPECT_EQ(s.format, "colmap");
  EXPECT_EQ(s.views.size(), 71u);
  EXPECT_TRUE(s.has_tracks);
  size_t n = 0;
  double err = median_reprojection_error(s, &n);
  EXPECT_GT(n, 10000u);
  EXPECT_LT(err, 1.0);
}

TEST(SceneReal, BeerCanLlffReprojection) {
  lrf::SceneOptions o;
  o.format = "llff";
  lrf::Scene s = lrf::load_scene(scene_dir("beer-can"), o);
  EXPECT_EQ(s.format, "llff");
  EXPECT_EQ(s.views.size(), 71u);
  size_t n = 0;
  double err = median_reprojection_error(s, &n);
  EXPECT_GT(n, 10000u);
  EXPECT_LT(err, 1.0);
}

TEST(SceneReal, BeerCanDownscaledAndCroppedKeepsGeometry) {
  lrf::SceneOptions o;
  o.downscale = 3;  // 720x1280 -> 240x427: the crop to a multiple of 8 removes 3 rows
  o.crop_to_multiple_of_8 = true;
  lrf::Scene s = lrf::load_scene(scene_dir("beer-can"), o);
  EXPECT_EQ(s.views[0].camera.width % 8, 0);
  EXPECT_EQ(s.views[0].camera.height % 8, 0);
  size_t n = 0;
  // Errors scale with the resolution: under 1 px at full size is under 1/3 px here.
  EXPECT_LT(median_reprojection_error(s, &n), 1.0 / 3);
  cv::Mat img = s.load_image(0);
  EXPECT_EQ(img.cols, s.views[0].camera.width);
  EXPECT_EQ(img.rows, s.views[0].camera.height);
}

TEST(SceneReal, FoxIsNerfWithDistortion) {
  lrf::SceneOptions o;
  o.downscale = 8;
  lrf::Scene s = lrf::load_scene(scene_dir("ngp-fox"), o);
  EXPECT_EQ(s.format, "nerf");
  EXPECT_EQ(s.views.size(), 67u);
  EXPECT_EQ(s.points.size(), 0u);
  EXPECT_TRUE(s.views[0].distortion.any());
  EXPECT_NEAR(s.views[0].camera.fx, 1375.52 * 135 / 1080, 1e-6);
  cv::Mat img = s.load_image(1);
  EXPECT_EQ(img.cols, 135);
  EXPECT_EQ(img.rows, 240);
}

}  // namespace
