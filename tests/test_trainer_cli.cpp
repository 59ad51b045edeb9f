// lrf train / render / eval end to end on the built-in synthetic scene, including the refusals.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "lrf/core/atomic_file.h"
#include "lrf/core/run_info.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

namespace {

struct Result {
  int code;
  std::string output;
};

Result lrf_run(const std::string& args) {
  const std::string cmd = std::string(LRF_BINARY) + " --threads 2 " + args + " 2>&1";
  Result r{0, ""};
  FILE* pipe = popen(cmd.c_str(), "r");
  char buffer[4096];
  size_t n;
  while ((n = fread(buffer, 1, sizeof buffer, pipe)) > 0) r.output.append(buffer, n);
  const int status = pclose(pipe);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

}  // namespace

TEST(TrainerCli, TrainRenderEvalOnSyntheticScene) {
  const fs::path root = fs::temp_directory_path() / "lrf_test_train_cli";
  fs::remove_all(root);
  const std::string scene = (root / "scene").string(), out = (root / "out").string();
  auto r = lrf_run("scene synth -o " + scene + " --views 12 --size 64x48 --points 1500");
  ASSERT_EQ(r.code, 0) << r.output;

  r = lrf_run("train " + scene + " --space voxels -o " + out);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find("--space"), std::string::npos) << r.output;

  r = lrf_run("-q train " + scene + " --space rgb -o " + out + " --iters 300 --sh-degree 1 --checkpoint-every 100 --max-gaussians 15000");
  ASSERT_EQ(r.code, 0) << r.output;
  for (auto f : {"point_cloud.ply", "config.json", "train_log.csv", "checkpoint.pt"})
    EXPECT_TRUE(fs::exists(fs::path(out) / f)) << f;
  auto config = lrf::read_json_file(out + "/config.json");
  EXPECT_EQ(config["resolution"][0], 64);
  EXPECT_TRUE(config.contains("command") && config.contains("versions"));
  EXPECT_EQ(config["result"]["steps"], 300);
  EXPECT_LE(config["result"]["gaussians"].get<int>(), 15000);

  // An existing folder is refused without --force / --resume.
  r = lrf_run("train " + scene + " -o " + out + " --iters 10");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find("exists"), std::string::npos) << r.output;

  r = lrf_run("-q eval " + out);
  ASSERT_EQ(r.code, 0) << r.output;
  auto metrics = lrf::read_json_file(out + "/metrics.json");
  EXPECT_EQ(metrics["views"].size(), 2u);  // views 0 and 8 of 12
  // Measured on this scene: the SfM-initialised field before training scores 11.4 dB on the test views.
  // After 300 steps capped at 15k Gaussians the training views reach 20.5-22.2 dB (mean of the last five
  // logged), while the test views land anywhere in 12.9-18.6 dB (SSIM 0.455-0.573; 24 runs: seeds 0-5,
  // 1 and 2 threads, two builds that differ only in float rounding): 10 views on a ring overfit, and
  // which way the held-out views go is chaotic. So the fit is held to a bound well up its range (the
  // untrained field's views are near 11 dB), the held-out views only to beating the untrained field.
  const std::string header = lrf::test::logged_header(out + "/train_log.csv");
  EXPECT_EQ(header.rfind("step,loss,psnr,", 0), 0u) << header;
  const std::vector<double> fit = lrf::test::logged_column(out + "/train_log.csv", 2);
  ASSERT_GE(fit.size(), 5u) << "train_log.csv has too few rows";
  double last_fit = 0;
  for (size_t k = fit.size() - 5; k < fit.size(); ++k) last_fit += fit[k] / 5;
  std::printf("synthetic 64x48, 300 steps: training views %.2f dB (last 5 logged), test PSNR %.2f dB, SSIM %.3f\n",
              last_fit, metrics["psnr"].get<double>(), metrics["ssim"].get<double>());
  EXPECT_GT(last_fit, 19.0);
  EXPECT_GT(metrics["psnr"].get<double>(), 12.0) << metrics.dump();
  EXPECT_GT(metrics["ssim"].get<double>(), 0.42);

  r = lrf_run("-q render " + out + " --split test --scale 2 -o " + (root / "renders").string());
  ASSERT_EQ(r.code, 0) << r.output;
  int images = 0;
  for (auto& e : fs::directory_iterator(root / "renders")) {
    auto m = cv::imread(e.path().string());
    EXPECT_EQ(m.cols, 128);
    EXPECT_EQ(m.rows, 96);
    ++images;
  }
  EXPECT_EQ(images, 2);

  // Resume a finished run to a longer one.
  r = lrf_run("-q train " + scene + " -o " + out + " --iters 320 --resume");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(lrf::read_json_file(out + "/config.json")["result"]["steps"], 320);

  // Damaged files are named in the error.
  lrf::write_file_atomic(out + "/checkpoint.pt", "garbage");
  r = lrf_run("train " + scene + " -o " + out + " --iters 330 --resume");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find("checkpoint.pt"), std::string::npos) << r.output;
  lrf::write_file_atomic(out + "/point_cloud.ply",
                         "ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nend_header\n");
  r = lrf_run("eval " + out);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find("point_cloud.ply"), std::string::npos) << r.output;
  fs::remove_all(root);
}

// --densify-grad reaches the densifier (a threshold no Gaussian reaches grows nothing, the default grows
// the field), is recorded and kept by --resume, and must be positive.
TEST(TrainerCli, DensifyGradControlsTheFieldsGrowth) {
  const fs::path root = fs::temp_directory_path() / "lrf_test_densify_grad";
  fs::remove_all(root);
  const std::string scene = (root / "scene").string();
  auto r = lrf_run("scene synth -o " + scene + " --views 10 --size 48x36 --points 600");
  ASSERT_EQ(r.code, 0) << r.output;
  const std::string grown = (root / "grown").string(), frozen = (root / "frozen").string();
  r = lrf_run("-q train " + scene + " -o " + grown + " --iters 200 --sh-degree 0");
  ASSERT_EQ(r.code, 0) << r.output;
  r = lrf_run("-q train " + scene + " -o " + frozen + " --iters 200 --sh-degree 0 --densify-grad 1e9");
  ASSERT_EQ(r.code, 0) << r.output;
  const auto a = lrf::read_json_file(grown + "/config.json"), b = lrf::read_json_file(frozen + "/config.json");
  const int start = b["init_points"]["points"].get<int>();
  EXPECT_GT(a["result"]["gaussians"].get<int>(), start);
  EXPECT_LE(b["result"]["gaussians"].get<int>(), start);
  EXPECT_EQ(b["options"]["densify_grad"].get<double>(), 1e9);

  r = lrf_run("-q train " + scene + " -o " + frozen + " --iters 220 --resume");
  ASSERT_EQ(r.code, 0) << r.output;
  const auto c = lrf::read_json_file(frozen + "/config.json");
  EXPECT_EQ(c["options"]["densify_grad"].get<double>(), 1e9);
  EXPECT_LE(c["result"]["gaussians"].get<int>(), start);

  r = lrf_run("train " + scene + " -o " + (root / "bad").string() + " --densify-grad 0");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find("--densify-grad"), std::string::npos) << r.output;
  fs::remove_all(root);
}
