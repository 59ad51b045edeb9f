// Triangulation from known poses (lrf scene points and the automatic initialisation): geometry on exact
// data, the synthetic scene's true surfaces, bad input, the cache, the files and the far shell.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "lrf/core/atomic_file.h"
#include "lrf/core/image_io.h"
#include "lrf/points/colmap_triangulation.h"
#include "lrf/points/far_shell.h"
#include "lrf/points/initial_points.h"
#include "lrf/points/points_cache.h"
#include "lrf/points/points_file.h"
#include "lrf/points/scene_triangulation.h"
#include "lrf/points/tracks.h"
#include "lrf/points/triangulation.h"
#include "lrf/points/view_pairs.h"
#include "lrf/scene/colmap_model.h"
#include "lrf/scene/scene.h"
#include "lrf/scene/synthetic_scene.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

namespace {

// The synthetic scene without SfM points. Its periodic textures make SIFT matches scarce (see
// test_correspondences.cpp): 48 views 7.5 degrees apart give ~300 points in ~8 s (12 views at 192x144 gave
// one matched pair).
const lrf::SyntheticOptions kNoPoints{48, "256x192", 7, 0};

std::vector<lrf::Camera> ring_cameras() { return lrf::synthetic_cameras(kNoPoints); }

// Copies a scene folder (to damage it without touching the shared copy).
std::string copy_scene(const std::string& from, const std::string& to) {
  fs::copy(from, to, fs::copy_options::recursive);
  return to;
}

double percentile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(q * (v.size() - 1))];
}

// Distance of x to the synthetic scene's surfaces along a viewing ray: from each camera that sees x, the
// surface hit is |t_hit - |x - c|| away from x; the smallest over the cameras. In pixels of that camera at
// x's depth (distance * f / depth), so near and far points are judged alike.
double surface_distance_px(const std::vector<lrf::Camera>& cameras, const Eigen::Vector3d& x) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& c : cameras) {
    Eigen::Vector2d px;
    double depth;
    if (!c.project(x, &px, &depth) || px.x() < 0 || px.y() < 0 || px.x() >= c.width || px.y() >= c.height) continue;
    Eigen::Vector3d d = x - c.center();
    const double dist = d.norm();
    double hit;
    lrf::synthetic_trace(c.center(), d / dist, kNoPoints.seed, &hit);
    best = std::min(best, std::abs(hit - dist) * c.fx / depth);
  }
  return best;
}

}  // namespace

TEST(Points, LinearTriangulationIsExactOnExactObservations) {
  auto cams = ring_cameras();
  const Eigen::Vector3d X(0.3, -0.2, 0.4);
  std::vector<lrf::PixelObservation> obs;
  for (int v : {0, 1, 2, 5}) {
    Eigen::Vector2d px;
    ASSERT_TRUE(cams[v].project(X, &px));
    obs.push_back({v, px});
  }
  Eigen::Vector3d Y;
  ASSERT_TRUE(lrf::triangulate_linear(cams, obs, &Y));
  EXPECT_LT((Y - X).norm(), 1e-9);
  // Refinement from a perturbed start comes back to the point.
  Eigen::Vector3d Z = X + Eigen::Vector3d(0.05, -0.03, 0.02);
  lrf::refine_point(cams, obs, &Z);
  EXPECT_LT((Z - X).norm(), 1e-8);
}

TEST(Points, RobustTriangulationDropsAWrongMatchAndADuplicateView) {
  auto cams = ring_cameras();
  const Eigen::Vector3d X(-0.4, 0.5, 0.1);
  std::vector<lrf::PixelObservation> obs;
  for (int v : {0, 1, 2, 3}) {
    Eigen::Vector2d px;
    ASSERT_TRUE(cams[v].project(X, &px));
    obs.push_back({v, px + Eigen::Vector2d(0.2, -0.1)});
  }
  obs.push_back({1, obs[1].pixel + Eigen::Vector2d(30, 5)});  // a second keypoint in view 1: a wrong match
  obs.push_back({4, Eigen::Vector2d(10, 10)});                // an outlier in view 4
  lrf::RobustPoint p;
  ASSERT_TRUE(lrf::triangulate_robust(cams, obs, {}, &p));
  EXPECT_EQ(p.inliers.size(), 4u);
  for (const auto& o : p.inliers) EXPECT_NE(o.view, 4);
  EXPECT_LT((p.xyz - X).norm(), 0.01);
  EXPECT_LT(p.mean_error_px, 0.5);
}

TEST(Points, ZeroBaselineIsNotTriangulated) {
  auto cams = ring_cameras();
  cams[1] = cams[0];  // the same camera twice: every ray through one centre
  std::vector<lrf::PixelObservation> obs = {{0, {50, 60}}, {1, {50, 60}}};
  Eigen::Vector3d X;
  EXPECT_FALSE(lrf::triangulate_linear(cams, obs, &X));
  lrf::RobustPoint p;
  EXPECT_FALSE(lrf::triangulate_robust(cams, obs, {}, &p));
}

TEST(Points, TracksJoinChainsOfMatches) {
  lrf::CorrespondenceSet set;
  using V = Eigen::Vector2f;
  lrf::ViewPairMatches ab;
  ab.view_i = 0, ab.view_j = 1;
  ab.xi = {V(10.5f, 20.5f), V(1, 1)};
  ab.xj = {V(11.5f, 21.5f), V(2, 2)};
  lrf::ViewPairMatches bc;
  bc.view_i = 1, bc.view_j = 2;
  bc.xi = {V(11.5f, 21.5f)};
  bc.xj = {V(12.5f, 22.5f)};
  set.pairs = {ab, bc};
  auto tracks = lrf::tracks_from_matches(set);
  ASSERT_EQ(tracks.size(), 2u);
  EXPECT_EQ(tracks[0].observations.size(), 3u);  // (0, 10.5, 20.5) - (1, 11.5, 21.5) - (2, 12.5, 22.5)
  EXPECT_EQ(tracks[1].observations.size(), 2u);
}

TEST(Points, PosePairsJoinRingNeighbours) {
  lrf::Scene s = lrf::load_scene(lrf::test::synthetic_scene(kNoPoints));
  std::vector<int> all(s.views.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  auto pairs = lrf::overlapping_view_pairs(s, all, 2);
  auto has = [&](int a, int b) { return std::count(pairs.begin(), pairs.end(), std::make_pair(a, b)) == 1; };
  EXPECT_TRUE(has(0, 1));
  EXPECT_TRUE(has(0, 47));   // the ring closes
  EXPECT_FALSE(has(0, 24));  // opposite sides look at each other: not a neighbour
}

// The points land on the scene's true surfaces. Along a viewing ray a point's error is its depth error,
// which is its keypoints' error divided by sin(triangulation angle); times sin(angle) it is back in image
// terms: the keypoints' localisation (median reprojection ~0.3 px here) times the ray's obliquity to the
// surface (the ring sees the ground at ~25 degrees: up to ~2.5x). Bound: median under 1 px, 90 % under
// 3 px (measured: 0.63 and 2.40; with exact observations the same code is exact to 1e-7). Phantom points
// from the scene's periodic textures would be many pixels off.
TEST(Points, SyntheticSceneIsTriangulatedOnItsSurfaces) {
  lrf::Scene s = lrf::load_scene(lrf::test::synthetic_scene(kNoPoints));
  ASSERT_TRUE(s.points.empty());
  auto r = lrf::triangulate_scene(s, {});
  EXPECT_GT(r.points.size(), 150u);
  EXPECT_LT(r.stats.median_error_px, 1.0);
  std::vector<lrf::Camera> cams;
  for (const auto& v : s.views) cams.push_back(v.camera);
  std::vector<double> d;
  for (const auto& p : r.points) {
    d.push_back(surface_distance_px(cams, p.xyz) * std::sin(p.angle_deg * M_PI / 180));
    EXPECT_GE(p.track_length, 3);
    EXPECT_LE(p.error_px, 2.0);
  }
  EXPECT_LT(percentile(d, 0.5), 1.0);
  EXPECT_LT(percentile(d, 0.9), 3.0);
  // Colours come from the images: the scene is lit and textured, far from black on average.
  double mean = 0;
  for (const auto& p : r.points) mean += p.rgb.mean();
  EXPECT_GT(mean / r.points.size(), 0.15);
}

TEST(Points, OneViewIsAClearError) {
  lrf::Scene s = lrf::load_scene(lrf::test::synthetic_scene(kNoPoints));
  s.views.resize(1);
  s.train_indices = {0};
  s.test_indices.clear();
  std::string e = lrf::test::error_of([&] { lrf::triangulate_scene(s, {}); });
  EXPECT_NE(e.find(s.root), std::string::npos) << e;
  EXPECT_NE(e.find("at least two views"), std::string::npos) << e;
}

TEST(Points, NoMatchesIsAClearErrorAndAutoFallsBackToRandom) {
  lrf::test::TempDir tmp("points_blank");
  const std::string root = copy_scene(lrf::test::synthetic_scene(kNoPoints), tmp / "scene");
  for (const auto& e : fs::directory_iterator(fs::path(root) / "images")) {
    lrf::write_image_rgb(e.path().string(), cv::Mat(192, 256, CV_32FC3, cv::Scalar(0.5, 0.5, 0.5)));
  }
  lrf::Scene s = lrf::load_scene(root);
  std::string e = lrf::test::error_of([&] { lrf::triangulate_scene(s, {}); });
  EXPECT_NE(e.find(root), std::string::npos) << e;
  EXPECT_NE(e.find("no view pair"), std::string::npos) << e;

  lrf::InitPointsOptions o;
  o.cache_dir = tmp / "cache";
  lrf::InitialPoints init = lrf::choose_initial_points(s, o);
  EXPECT_TRUE(init.points.empty());
  EXPECT_EQ(init.source, "random");
  EXPECT_NE(init.record.value("reason", std::string()).find("triangulation failed"), std::string::npos);
  // The failure is cached too: the next field of the same scene falls back without matching again.
  auto again = lrf::find_cached_triangulation(s, [&] { auto t = o.triangulation; t.training_views_only = true; return t; }(),
                                              o.cache_dir);
  EXPECT_TRUE(again.hit);
  EXPECT_FALSE(again.failure.empty());
}

TEST(Points, ZeroBaselineSceneIsAClearError) {
  // Every view the same camera and image: matches are perfect, but no ray pair has an angle.
  lrf::Scene s = lrf::load_scene(lrf::test::synthetic_scene(kNoPoints));
  s.views.resize(4);
  for (auto& v : s.views) v = s.views[1];
  s.train_indices = {0, 1, 2, 3};
  s.test_indices.clear();
  std::string e = lrf::test::error_of([&] { lrf::triangulate_scene(s, {}); });
  EXPECT_NE(e.find(s.root), std::string::npos) << e;
  EXPECT_NE(e.find("no point survived"), std::string::npos) << e;
  EXPECT_NE(e.find("under at least"), std::string::npos) << e;  // says which filter rejected them
}

TEST(Points, CacheIsReusedAndInvalidatedWhenAnImageChanges) {
  lrf::test::TempDir tmp("points_cache");
  const std::string root = copy_scene(lrf::test::synthetic_scene(kNoPoints), tmp / "scene");
  lrf::TriangulationOptions o;
  o.neighbours = 4;
  o.training_views_only = true;
  const std::string cache = tmp / "cache";
  auto listing = [&] {
    std::vector<std::string> files;
    for (const auto& e : fs::recursive_directory_iterator(root)) files.push_back(e.path().string());
    std::sort(files.begin(), files.end());
    return files;
  };
  const auto before = listing();
  lrf::Scene s = lrf::load_scene(root);
  const std::string key_before = lrf::triangulation_cache_key(s, o);
  auto first = lrf::triangulate_cached(s, o, cache);
  ASSERT_TRUE(first.failure.empty()) << first.failure;
  EXPECT_FALSE(first.hit);
  auto second = lrf::triangulate_cached(s, o, cache);
  EXPECT_TRUE(second.hit);
  ASSERT_EQ(second.points.size(), first.points.size());
  for (size_t k = 0; k < first.points.size(); ++k) EXPECT_LT((second.points[k].xyz - first.points[k].xyz).norm(), 1e-12);
  EXPECT_EQ(listing(), before);  // nothing is written into the scene folder

  // A training view's image changes: a new entry.
  const std::string image = s.views[static_cast<size_t>(s.train_indices[0])].image_path;
  cv::Mat img = lrf::read_image_rgb(image);
  cv::flip(img, img, 1);
  lrf::write_image_rgb(image, img);
  lrf::Scene changed = lrf::load_scene(root);
  EXPECT_NE(lrf::triangulation_cache_key(changed, o), key_before);
  auto third = lrf::triangulate_cached(changed, o, cache);
  EXPECT_FALSE(third.hit);
  // And a resolution change is another entry too.
  lrf::SceneOptions half;
  half.downscale = 2;
  EXPECT_NE(lrf::triangulation_cache_key(lrf::load_scene(root, half), o), lrf::triangulation_cache_key(changed, o));
  // A damaged entry is recomputed, not trusted.
  lrf::write_file_atomic(lrf::triangulation_cache_path(cache, lrf::triangulation_cache_key(changed, o)), "{not json");
  EXPECT_FALSE(lrf::triangulate_cached(changed, o, cache).hit);
}

TEST(Points, FilesRoundTrip) {
  lrf::test::TempDir tmp("points_files");
  std::vector<lrf::TriangulatedPoint> pts(3);
  for (int k = 0; k < 3; ++k) {
    pts[k].xyz = Eigen::Vector3d(k, -k * 0.5, 1.25 + k);
    pts[k].rgb = Eigen::Vector3f(0.2f * k, 0.5f, 1.0f);
    pts[k].error_px = 0.25 * k;
  }
  for (const char* name : {"p.bin", "p.txt"}) {
    lrf::write_points_file(tmp / name, pts);
    auto back = lrf::read_colmap_points(tmp / name);
    ASSERT_EQ(back.size(), 3u);
    for (int k = 0; k < 3; ++k) {
      EXPECT_LT((back[k].xyz - pts[k].xyz).norm(), 1e-12);
      EXPECT_NEAR(back[k].error, pts[k].error_px, 1e-12);
      EXPECT_NEAR(back[k].rgb[0], pts[k].rgb[0], 0.5 / 255);
    }
    EXPECT_EQ(lrf::read_points_file(tmp / name).size(), 3u);
  }
  lrf::write_points_file(tmp / "p.ply", pts);
  const std::string ply = lrf::read_file(tmp / "p.ply");
  EXPECT_EQ(ply.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
  EXPECT_NE(ply.find("element vertex 3\n"), std::string::npos);
  EXPECT_EQ(ply.size() - (ply.find("end_header\n") + 11), 3u * 15u);
  EXPECT_NE(lrf::test::error_of([&] { lrf::write_points_file(tmp / "p.xyz", pts); }).find("p.xyz"), std::string::npos);
  EXPECT_NE(lrf::test::error_of([&] { lrf::read_points_file(tmp / "missing.bin"); }).find("missing.bin"), std::string::npos);
}

TEST(Points, InitPointsModes) {
  lrf::Scene with = lrf::load_scene(lrf::test::synthetic_scene());  // has SfM points
  lrf::InitPointsOptions o;
  EXPECT_EQ(lrf::choose_initial_points(with, o).source, "file");
  o.mode = "random";
  auto r = lrf::choose_initial_points(with, o);
  EXPECT_EQ(r.source, "random");
  EXPECT_TRUE(r.points.empty());
  EXPECT_EQ(r.record.value("mode", std::string()), "random");
  o.mode = "nonsense";
  EXPECT_NE(lrf::test::error_of([&] { lrf::choose_initial_points(with, o); }).find("--init-points"), std::string::npos);
  o.mode = "/no/such/points3D.bin";
  EXPECT_NE(lrf::test::error_of([&] { lrf::choose_initial_points(with, o); }).find("/no/such/points3D.bin"),
            std::string::npos);
}

// The rule recorded for a K-view field is the one its start is triangulated with, and only modes that
// triangulate have one: a field started from random points or a file must not claim a track rule.
TEST(Points, FewShotTrackRuleIsTheRuleOfTheTriangulatingModes) {
  lrf::TriangulationOptions training;
  training.training_views_only = true;
  const int rule = lrf::few_shot_triangulation(3, training).min_track_length;
  EXPECT_EQ(rule, 2);  // two-view tracks: see few_shot_triangulation
  EXPECT_EQ(lrf::few_shot_track_rule("auto", 3), std::optional<int>(rule));
  EXPECT_EQ(lrf::few_shot_track_rule("triangulate", 3), std::optional<int>(rule));
  EXPECT_FALSE(lrf::few_shot_track_rule("random", 3).has_value());
  EXPECT_FALSE(lrf::few_shot_track_rule("points3D.bin", 3).has_value());
  EXPECT_FALSE(lrf::few_shot_track_rule("auto", 0).has_value());  // the full split keeps the scene's points
  EXPECT_GT(lrf::few_shot_triangulation(0, training).min_track_length, rule);
}

TEST(Points, FarShellLiesBeyondThePointsWhereViewsLook) {
  lrf::Scene s = lrf::load_scene(lrf::test::synthetic_scene());
  lrf::FarShellOptions o;
  o.points = 2000;
  auto shell = lrf::far_shell_points(s, s.points, o);
  EXPECT_GT(shell.size(), 100u);
  EXPECT_LT(shell.size(), 2000u);  // the ring of cameras does not see straight up or down
  double reach = 0;
  for (const auto& v : s.views) reach = std::max(reach, v.camera.center().norm());
  for (const auto& p : shell) EXPECT_GT(p.xyz.norm(), 1.5 * reach);
}

TEST(Points, MissingColmapIsAClearError) {
  EXPECT_FALSE(lrf::colmap_available("/nonexistent/colmap"));
  lrf::Scene s = lrf::load_scene(lrf::test::synthetic_scene(kNoPoints));
  lrf::ColmapTriangulationOptions c;
  c.colmap = "/nonexistent/colmap";
  std::string e = lrf::test::error_of([&] { lrf::triangulate_with_colmap(s, {}, c); });
  EXPECT_NE(e.find("not installed"), std::string::npos) << e;
}

// The command line end to end: scene points writes its files, train records where its points came from.
TEST(PointsCli, ScenePointsAndTrainRecords) {
  lrf::test::TempDir tmp("points_cli");
  const std::string scene = lrf::test::synthetic_scene(kNoPoints);
  auto r = lrf::test::run_lrf("-q scene points '" + scene + "' -o '" + (tmp / "p.bin") + "' -o '" + (tmp / "p.ply") +
                              "' --neighbours 4 --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(tmp / "p.bin"));
  EXPECT_TRUE(fs::exists(tmp / "p.ply"));
  EXPECT_GT(lrf::read_colmap_points(tmp / "p.bin").size(), 200u);
  EXPECT_NE(r.output.find("\"points\":"), std::string::npos) << r.output;

  const std::string cache = tmp / "cache";
  r = lrf::test::run_lrf("-q train '" + scene + "' -o '" + (tmp / "tri") + "' --iters 2 --cache-dir '" + cache + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  auto config = nlohmann::json::parse(lrf::read_file(tmp / "tri/config.json"));
  EXPECT_EQ(config["init_points"]["source"], "triangulated") << config["init_points"].dump();
  EXPECT_EQ(config["init_points"]["mode"], "auto");
  EXPECT_TRUE(fs::is_directory(fs::path(cache) / "points"));

  r = lrf::test::run_lrf("-q train '" + scene + "' -o '" + (tmp / "rand") + "' --iters 2 --init-points random --cache-dir '" +
                         cache + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  config = nlohmann::json::parse(lrf::read_file(tmp / "rand/config.json"));
  EXPECT_EQ(config["init_points"]["source"], "random");

  r = lrf::test::run_lrf("-q train '" + scene + "' -o '" + (tmp / "file") + "' --iters 2 --init-points '" + (tmp / "p.bin") +
                         "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  config = nlohmann::json::parse(lrf::read_file(tmp / "file/config.json"));
  EXPECT_EQ(config["init_points"]["source"], "file");

  r = lrf::test::run_lrf("scene info '" + scene + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("init from  triangulated"), std::string::npos) << r.output;
  r = lrf::test::run_lrf("scene points '" + scene + "' --help");
  for (const char* option : {"--output", "--with", "--views", "--database", "--neighbours", "--max-error", "--min-angle",
                             "--min-track-length", "--reference", "--cache-dir", "--colmap-work"}) {
    EXPECT_NE(r.output.find(option), std::string::npos) << option;
  }
}
