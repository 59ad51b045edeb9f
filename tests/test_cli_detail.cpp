// The detail pass from the command line: lrf eval --detail scores a field's test views with it, borrowing
// only training photographs; lrf render --path --detail draws a path with it and measures its stability.
#include <filesystem>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "field_helpers.h"
#include "lrf/core/run_info.h"
#include "lrf/scene/scene.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

namespace {

std::string q(const std::string& s) { return "'" + s + "'"; }

// A private copy of a shared tiny field, since the commands write into the folder they are given.
std::string copy_of(const std::string& field, const lrf::test::TempDir& dir) {
  const std::string copy = dir / "field";
  fs::copy(field, copy, fs::copy_options::recursive);
  return copy;
}

}  // namespace

TEST(CliDetail, EvalBorrowsOnlyTrainingPhotographsAndRecordsThem) {
  lrf::test::TempDir dir("cli_detail_eval");
  const std::string field = copy_of(lrf::test::tiny_field("latent"), dir);
  auto r = lrf::test::run_lrf("--threads 2 -q eval " + q(field) + " --detail --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto m = lrf::read_json_file(field + "/detail/metrics.json");
  ASSERT_TRUE(m["psnr"].is_number()) << m.dump();
  EXPECT_GT(m["psnr"].get<double>(), 5.0);
  EXPECT_GT(m["detail_ms"].get<double>(), 0.0);
  // Borrowed views are named, and none of them is a test view.
  const auto config = lrf::read_json_file(field + "/config.json");
  lrf::SceneOptions so;
  so.crop_to_multiple_of_8 = true;
  const lrf::Scene scene = lrf::load_scene(config["scene"].get<std::string>(), so);
  std::set<std::string> test_names;
  for (int i : scene.test_indices) test_names.insert(scene.views[i].name);
  ASSERT_FALSE(m["borrowed_views"].empty()) << m.dump();
  for (const auto& name : m["borrowed_views"]) EXPECT_EQ(test_names.count(name.get<std::string>()), 0u) << name;
  EXPECT_EQ(m["detail"]["views"], 3);
  EXPECT_TRUE(fs::exists(field + "/detail/eval"));
  // The field's own scores are not touched by the pass.
  EXPECT_FALSE(fs::exists(field + "/metrics.json") &&
               lrf::read_json_file(field + "/metrics.json").contains("borrowed_views"));

  // Its options reach the pass: one photograph per frame.
  r = lrf::test::run_lrf("--threads 2 -q eval " + q(field) + " --detail --detail-views 1 --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(lrf::read_json_file(field + "/detail/metrics.json")["detail"]["views"], 1);
  // Bad values are usage errors.
  r = lrf::test::run_lrf("-q eval " + q(field) + " --detail --detail-views 0");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = lrf::test::run_lrf("-q eval " + q(field) + " --detail --scale 2");
  EXPECT_EQ(r.exit_code, 2) << r.output;
}

TEST(CliDetail, RenderPathWithDetailMeasuresItsStability) {
  lrf::test::TempDir dir("cli_detail_render");
  const std::string field = copy_of(lrf::test::tiny_field("rgb"), dir);
  auto r = lrf::test::run_lrf("--threads 2 -q render " + q(field) + " --path interp --frames 4 --detail --stability "
                              "--frames-dir " + q(dir / "frames"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(dir / "frames/frame_0003.png"));
  const auto at = r.output.find("{\"warp_error\": ");
  ASSERT_NE(at, std::string::npos) << r.output;
  const double error = std::stod(r.output.substr(at + 15));
  EXPECT_GE(error, 0.0);
  EXPECT_LT(error, 128.0);
  // --detail and --stability belong to a path.
  r = lrf::test::run_lrf("-q render " + q(field) + " --detail");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = lrf::test::run_lrf("-q render " + q(field) + " --stability");
  EXPECT_EQ(r.exit_code, 2) << r.output;
}
