// An RGB row of lrf compare is an RGB run like any other: lrf eval scores it as compare did (the same
// metrics.json keys, the rendered views, LPIPS when weights are given), and lrf train --resume continues it,
// also a row that compare recorded under its older option names.
#include <filesystem>
#include <set>
#include <string>

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "lrf/compare/compare.h"
#include "lrf/core/atomic_file.h"
#include "lrf/core/run_info.h"
#include "lrf/core/safetensors.h"
#include "lrf/eval/lpips.h"
#include "lrf/splat/run/train_run.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

namespace {

lrf::CompareOptions tiny_rgb_compare(const std::string& out) {
  lrf::CompareOptions o;
  o.scene = lrf::test::synthetic_scene();
  o.out = out;
  o.autoencoder = lrf::test::shared_dir() + "/models/taef2";
  o.iters = 40;
  o.methods = {"rgb/8"};
  return o;
}

std::set<std::string> keys(const nlohmann::json& j) {
  std::set<std::string> k;
  for (const auto& [key, value] : j.items()) k.insert(key);
  return k;
}

size_t png_count(const std::string& dir) {
  size_t n = 0;
  if (!fs::exists(dir)) return 0;
  for (const auto& e : fs::directory_iterator(dir)) n += e.path().extension() == ".png";
  return n;
}

// Weights of the right layout with random values: enough for LPIPS to run (the value is not checked).
std::string random_lpips_weights(const std::string& path) {
  lrf::StateDict sd;
  for (const auto& [key, shape] : lrf::Lpips::expected_keys())
    if (key.rfind("scaling_layer.", 0) != 0) sd.insert(key, torch::rand(shape) * 0.1);
  // The loader checks these against LPIPS v0.1's constants.
  sd.insert("scaling_layer.shift", torch::tensor({-0.030f, -0.088f, -0.188f}).view({1, 3, 1, 1}));
  sd.insert("scaling_layer.scale", torch::tensor({0.458f, 0.448f, 0.450f}).view({1, 3, 1, 1}));
  lrf::write_safetensors(path, sd);
  return path;
}

}  // namespace

TEST(RgbRun, EvalOfACompareRowWritesWhatCompareWrote) {
  lrf::test::TempDir dir("rgb_run_eval");
  lrf::run_compare(tiny_rgb_compare(dir / "cmp"));
  const std::string row = dir / "cmp/rgb_8";
  const nlohmann::json by_compare = lrf::read_json_file(row + "/metrics.json");
  const size_t views = by_compare["views"].size();
  ASSERT_GT(views, 0u);
  fs::remove_all(row + "/eval");
  fs::remove(row + "/metrics.json");

  auto r = lrf::test::run_lrf("--threads 2 -q eval '" + row + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json by_eval = lrf::read_json_file(row + "/metrics.json");
  EXPECT_EQ(keys(by_eval), keys(by_compare)) << by_eval.dump() << "\n" << by_compare.dump();
  // The same renders scored the same way.
  EXPECT_DOUBLE_EQ(by_eval["psnr"].get<double>(), by_compare["psnr"].get<double>());
  EXPECT_DOUBLE_EQ(by_eval["ssim"].get<double>(), by_compare["ssim"].get<double>());
  EXPECT_EQ(png_count(row + "/eval"), views);
  EXPECT_GT(by_eval["render_fps"].get<double>(), 0.0);
  EXPECT_GT(by_eval["storage_mb"].get<double>(), 0.0);
  EXPECT_GT(by_eval["train_seconds"].get<double>(), 0.0);
  EXPECT_TRUE(by_eval["lpips"].is_null());

  // LPIPS weights are taken for an RGB run too.
  const std::string weights = random_lpips_weights(dir / "lpips.safetensors");
  r = lrf::test::run_lrf("--threads 2 -q eval '" + row + "' --lpips-weights '" + weights + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json with_lpips = lrf::read_json_file(row + "/metrics.json");
  EXPECT_TRUE(with_lpips["lpips"].is_number()) << with_lpips.dump();
  EXPECT_FALSE(with_lpips.contains("lpips_reason"));
  // --decoder is still refused: an RGB field has none.
  r = lrf::test::run_lrf("eval '" + row + "' --decoder x.safetensors");
  EXPECT_EQ(r.exit_code, 2) << r.output;
}

TEST(RgbRun, TrainResumesACompareRowInterruptedOrFinished) {
  lrf::test::TempDir dir("rgb_run_resume");
  lrf::run_compare(tiny_rgb_compare(dir / "cmp"));
  const std::string row = dir / "cmp/rgb_8", config_path = row + "/config.json";
  const auto recorded = lrf::read_json_file(config_path);
  EXPECT_EQ(recorded["options"]["factor"], 8);
  EXPECT_EQ(recorded["options"]["crop8"], true);

  // Interrupted after its last checkpoint: --resume finishes it, the folder in place of the scene and -o.
  nlohmann::json unfinished = recorded;
  unfinished.erase("result");
  lrf::write_json_file(config_path, unfinished);
  auto r = lrf::test::run_lrf("--threads 2 -q train '" + row + "' --resume");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(lrf::splat::run_finished(row));
  EXPECT_EQ(lrf::read_json_file(config_path)["result"]["steps"], 40);

  // Finished: continued to more steps, still on the views reduced 8x that compare trained it on.
  r = lrf::test::run_lrf("--threads 2 -q train '" + row + "' --resume --iters 60 -o '" + row + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  auto config = lrf::read_json_file(config_path);
  EXPECT_EQ(config["result"]["steps"], 60);
  EXPECT_EQ(config["options"]["factor"], 8);
  EXPECT_EQ(config["options"]["iters"], 60);
  EXPECT_EQ(config["train_resolution"], recorded["train_resolution"]);
  EXPECT_EQ(config["resolution"], recorded["resolution"]);
  EXPECT_NE(lrf::read_file(row + "/train_log.csv").find("\n60,"), std::string::npos);

  // A row recorded before compare trained its RGB rows with lrf train's job: only these options.
  config["options"] = {
      {"scene", recorded["options"]["scene"]}, {"iters", 60}, {"mip", false}, {"seed", 0}, {"factor", 8}};
  lrf::write_json_file(config_path, config);
  r = lrf::test::run_lrf("--threads 2 -q train '" + row + "' --resume --iters 70");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  config = lrf::read_json_file(config_path);
  EXPECT_EQ(config["result"]["steps"], 70);
  EXPECT_EQ(config["train_resolution"], recorded["train_resolution"]);
  EXPECT_EQ(config["options"]["images"], recorded["options"]["images"]);

  // Without --resume the folder cannot stand in for -o.
  r = lrf::test::run_lrf("train '" + lrf::test::synthetic_scene() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--out"), std::string::npos) << r.output;
}
