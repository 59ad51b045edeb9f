// Correspondences: file format, sources (tracks, SIFT matcher) and their epipolar error under known poses.
#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "lrf/align/correspondences.h"
#include "lrf/align/correspondences_database.h"
#include "lrf/align/correspondences_matching.h"
#include "lrf/align/correspondences_io.h"
#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "test_helpers.h"

namespace {

TEST(Correspondences, SequentialPairsFollowColmap) {
  // overlap 2, no quadratic: (i, i+1), (i, i+2).
  auto p = lrf::sequential_pairs(5, 2, 0);
  EXPECT_EQ(p.size(), 4u + 3u);
  // overlap 2 + quadratic: i + 2^0 and i + 2^1 are already there; nothing new.
  EXPECT_EQ(lrf::sequential_pairs(5, 2, 1).size(), 7u);
  // overlap 3 + quadratic adds i + 4 (k = 2).
  auto q = lrf::sequential_pairs(8, 3, 1);
  EXPECT_NE(std::find(q.begin(), q.end(), std::make_pair(0, 4)), q.end());
  EXPECT_EQ(std::find(q.begin(), q.end(), std::make_pair(0, 5)), q.end());
}

TEST(Correspondences, EpipolarDistanceIsZeroForTrueMatchesAndGrowsOffTheLine) {
  lrf::Scene s = lrf::load_scene(lrf::test::synthetic_scene());
  auto set = lrf::correspondences_from_tracks(s, 15);
  ASSERT_FALSE(set.pairs.empty());
  const auto& p = set.pairs[0];
  const auto& ci = s.views[p.view_i].camera;
  const auto& cj = s.views[p.view_j].camera;
  Eigen::Vector2d a = p.xi[0].cast<double>(), b = p.xj[0].cast<double>();
  EXPECT_LT(lrf::epipolar_distance(ci, cj, a, b), 1e-3);  // float32 pixel storage
  // Moving the match along the image by 5 px moves it off the epipolar line by at most 5 px, and by
  // more than 0 unless the motion is along the line: test with both axes.
  double dx = lrf::epipolar_distance(ci, cj, a, b + Eigen::Vector2d(5, 0));
  double dy = lrf::epipolar_distance(ci, cj, a, b + Eigen::Vector2d(0, 5));
  EXPECT_LE(std::max(dx, dy), 5.0 + 1e-3);
  EXPECT_GT(std::hypot(dx, dy), 4.99);  // the line's normal is a unit vector: dx^2 + dy^2 = 25
}

TEST(Correspondences, TracksOfTheSyntheticSceneAreExact) {
  lrf::Scene s = lrf::load_scene(lrf::test::synthetic_scene());
  auto set = lrf::correspondences_from_tracks(s, 15);
  auto sum = lrf::summarize(set, s);
  EXPECT_GT(sum.pairs, 5u);
  EXPECT_LT(sum.epipolar_median_px, 1e-3);
  auto train_only = lrf::correspondences_from_tracks(s, 15, true);
  for (const auto& p : train_only.pairs) {
    EXPECT_NE(p.view_i, 0);  // view 0 is the test view of an 8-view scene
    EXPECT_NE(p.view_j, 0);
  }
}

// The synthetic scene's periodic textures (checkers, stripes) and dominant ground plane make SIFT matches
// ambiguous and the fundamental matrix degenerate, so geometric accuracy is tested on the real beer-can
// below; here: the matcher's pair rules and the test-view exclusion.
TEST(Correspondences, MatcherKeepsOnlyPairsThatPassItsRules) {
  lrf::Scene s = lrf::load_scene(lrf::test::synthetic_scene({12, "256x192", 2, 200}));
  lrf::MatchOptions o;
  o.training_views_only = true;
  o.min_inliers = 16;
  auto set = lrf::correspondences_from_matching(s, o);  // throws if no pair passes
  EXPECT_GE(set.pairs.size(), 1u);
  for (const auto& p : set.pairs) {
    EXPECT_GE(p.xi.size(), 16u);
    EXPECT_LT(p.view_i, p.view_j);
    EXPECT_NE(p.view_i % 8, 0);  // views 0 and 8 are test views
    EXPECT_NE(p.view_j % 8, 0);
  }
}

TEST(Correspondences, BeerCanTracksAndMatcherUnderKnownPoses) {
  lrf::SceneOptions so;
  so.downscale = 4;  // 180x320: keeps the test fast
  lrf::Scene s = lrf::load_scene(lrf::test::scene_dir("beer-can"), so);
  auto tracks = lrf::summarize(lrf::correspondences_from_tracks(s, 15), s);
  EXPECT_GT(tracks.pairs, 500u);
  EXPECT_LT(tracks.epipolar_median_px, 1.5);
  lrf::MatchOptions o;
  o.sequential_overlap = 3;
  auto match = lrf::summarize(lrf::correspondences_from_matching(s, o), s);
  EXPECT_GT(match.pairs, 20u);
  EXPECT_LT(match.epipolar_median_px, 1.5);
}

TEST(Correspondences, FileRoundTripAndCorruption) {
  lrf::Scene s = lrf::load_scene(lrf::test::synthetic_scene());
  auto set = lrf::correspondences_from_tracks(s, 15);
  lrf::test::TempDir tmp("corr");
  std::string path = tmp / "c.corr";
  lrf::write_correspondences(path, set);
  auto back = lrf::read_correspondences(path);
  ASSERT_EQ(back.pairs.size(), set.pairs.size());
  EXPECT_EQ(back.view_names, set.view_names);
  EXPECT_EQ(back.pairs[1].xj, set.pairs[1].xj);
  std::string bytes = lrf::read_file(path);
  EXPECT_THROW(lrf::parse_correspondences(bytes.substr(0, bytes.size() - 3), path), lrf::Error);
  EXPECT_THROW(lrf::parse_correspondences("LRFCORR1\xff\xff\xff\x7f", path), lrf::Error);
  EXPECT_THROW(lrf::parse_correspondences("garbage", path), lrf::Error);
}

TEST(Correspondences, SceneWithoutTracksIsAClearError) {
  lrf::SceneOptions so;
  so.images_dir = "images_8";
  lrf::Scene fern = lrf::load_scene(lrf::test::scene_dir("llff-fern"), so);
  try {
    lrf::correspondences_from_tracks(fern, 15);
    FAIL();
  } catch (const lrf::Error& e) {
    EXPECT_NE(std::string(e.what()).find("no COLMAP tracks"), std::string::npos);
  }
}

}  // namespace

#include <sqlite3.h>

namespace {

void exec(sqlite3* db, const std::string& sql) {
  char* err = nullptr;
  ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err), SQLITE_OK) << (err ? err : "");
}

void insert_blob(sqlite3* db, const char* sql, int64_t id, int64_t rows, int64_t cols, const void* data, int bytes) {
  sqlite3_stmt* st = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, sql, -1, &st, nullptr), SQLITE_OK);
  sqlite3_bind_int64(st, 1, id);
  sqlite3_bind_int64(st, 2, rows);
  sqlite3_bind_int64(st, 3, cols);
  sqlite3_bind_blob(st, 4, data, bytes, SQLITE_TRANSIENT);
  ASSERT_EQ(sqlite3_step(st), SQLITE_DONE);
  sqlite3_finalize(st);
}

// A COLMAP database made from the synthetic scene's tracks (keypoints = observations, inlier matches =
// shared points) reads back as the same correspondences the tracks give.
TEST(Correspondences, ColmapDatabaseMatchesTheTracks) {
  lrf::Scene s = lrf::load_scene(lrf::test::synthetic_scene());
  lrf::test::TempDir tmp("colmap_db");
  std::string path = tmp / "database.db";
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  exec(db, "CREATE TABLE images (image_id INTEGER PRIMARY KEY, name TEXT, camera_id INTEGER);"
           "CREATE TABLE keypoints (image_id INTEGER, rows INTEGER, cols INTEGER, data BLOB);"
           "CREATE TABLE two_view_geometries (pair_id INTEGER, rows INTEGER, cols INTEGER, data BLOB, config INTEGER);");
  for (size_t v = 0; v < s.views.size(); ++v) {
    exec(db, "INSERT INTO images VALUES (" + std::to_string(v + 1) + ", '" + s.views[v].name + "', 1);");
    std::vector<float> kp;
    for (const auto& ob : s.views[v].observations) {
      kp.push_back(static_cast<float>(ob.pixel.x()));
      kp.push_back(static_cast<float>(ob.pixel.y()));
    }
    insert_blob(db, "INSERT INTO keypoints VALUES (?, ?, ?, ?)", int64_t(v + 1), int64_t(kp.size() / 2), 2, kp.data(),
                static_cast<int>(kp.size() * 4));
  }
  size_t expected_pairs = 0;
  for (size_t a = 0; a < s.views.size(); ++a) {
    for (size_t b = a + 1; b < s.views.size(); ++b) {
      std::vector<uint32_t> idx;
      const auto& oa = s.views[a].observations;
      const auto& ob = s.views[b].observations;
      for (size_t i = 0; i < oa.size(); ++i)
        for (size_t j = 0; j < ob.size(); ++j)
          if (oa[i].point_id == ob[j].point_id) idx.insert(idx.end(), {uint32_t(i), uint32_t(j)});
      if (idx.size() / 2 < 15) continue;
      ++expected_pairs;
      int64_t pair = int64_t(a + 1) * 2147483647 + int64_t(b + 1);
      insert_blob(db, "INSERT INTO two_view_geometries (pair_id, rows, cols, data) VALUES (?, ?, ?, ?)", pair,
                  int64_t(idx.size() / 2), 2, idx.data(), static_cast<int>(idx.size() * 4));
    }
  }
  sqlite3_close(db);
  auto set = lrf::correspondences_from_database(s, path, 15);
  EXPECT_EQ(set.pairs.size(), expected_pairs);
  EXPECT_LT(lrf::summarize(set, s).epipolar_median_px, 1e-3);
  EXPECT_THROW(lrf::correspondences_from_database(s, tmp / "missing.db", 15), lrf::Error);
}

}  // namespace
