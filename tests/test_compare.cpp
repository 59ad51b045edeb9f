// lrf compare on a tiny synthetic scene: the table is written, finished methods are reused, and a method
// whose run was interrupted is finished from its checkpoint before it is scored, never scored as it was.
#include <filesystem>

#include <gtest/gtest.h>

#include "lrf/compare/compare.h"
#include "lrf/core/atomic_file.h"
#include "lrf/core/run_info.h"
#include "lrf/splat/run/train_run.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

namespace {

lrf::CompareOptions tiny_compare(const std::string& out) {
  lrf::CompareOptions o;
  o.scene = lrf::test::synthetic_scene();
  o.out = out;
  o.autoencoder = lrf::test::shared_dir() + "/models/taef2";
  o.cache_dir = "";
  o.iters = 40;
  o.methods = {"rgb/8", "latent"};
  return o;
}

// What an interruption leaves: a checkpoint and the point_cloud.ply it refreshed, but no "result" in
// config.json. The metrics.json beside it is made recognisable, as if scored from that unfinished field.
void make_unfinished(const fs::path& dir) {
  const std::string config_path = (dir / "config.json").string(), metrics_path = (dir / "metrics.json").string();
  nlohmann::json config = lrf::read_json_file(config_path);
  config.erase("result");
  lrf::write_json_file(config_path, config);
  nlohmann::json metrics = lrf::read_json_file(metrics_path);
  metrics["psnr"] = -1.0;
  lrf::write_json_file(metrics_path, metrics);
}

TEST(Compare, ReusesFinishedMethodsAndFinishesInterruptedOnesBeforeScoring) {
  lrf::test::TempDir dir("compare");
  lrf::CompareOptions o = tiny_compare(dir / "cmp");
  lrf::run_compare(o);
  for (const char* f : {"table.csv", "table.md", "report.html", "rgb_8/metrics.json", "latent/metrics.json"}) {
    EXPECT_TRUE(fs::exists(dir / ("cmp/" + std::string(f)))) << f;
  }
  ASSERT_TRUE(lrf::splat::run_finished(dir / "cmp/rgb_8"));
  ASSERT_TRUE(lrf::splat::run_finished(dir / "cmp/latent"));

  // A second call reuses both: no field is rewritten.
  const auto rgb_time = fs::last_write_time(dir / "cmp/rgb_8/point_cloud.ply");
  const auto latent_time = fs::last_write_time(dir / "cmp/latent/point_cloud.ply");
  lrf::run_compare(o);
  EXPECT_EQ(fs::last_write_time(dir / "cmp/rgb_8/point_cloud.ply"), rgb_time);
  EXPECT_EQ(fs::last_write_time(dir / "cmp/latent/point_cloud.ply"), latent_time);

  // Both runs interrupted (after their last checkpoint): the next call finishes them and scores again.
  make_unfinished(dir / "cmp/rgb_8");
  make_unfinished(dir / "cmp/latent");
  ASSERT_FALSE(lrf::splat::run_finished(dir / "cmp/rgb_8"));
  lrf::run_compare(o);
  const fs::path cmp = dir / "cmp";
  for (const char* m : {"rgb_8", "latent"}) {
    SCOPED_TRACE(m);
    EXPECT_TRUE(lrf::splat::run_finished((cmp / m).string()));
    EXPECT_GT(lrf::read_json_file((cmp / m / "metrics.json").string()).value("psnr", -1.0), 0.0);
  }
  const std::string table = lrf::read_file(dir / "cmp/table.csv");
  EXPECT_EQ(table.find("-1"), std::string::npos) << table;
  EXPECT_EQ(table.rfind("method,psnr,ssim,ms_ssim,flip,lpips,", 0), 0u) << table;
  const double flip = lrf::read_json_file((cmp / "latent" / "metrics.json").string()).value("flip", -1.0);
  EXPECT_GT(flip, 0.0);
  EXPECT_LT(flip, 1.0);
}

}  // namespace
