// The Stage II commands end to end through the CLI: train --space latent, render, eval, and refusals.
#include <filesystem>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "lrf/core/run_info.h"
#include "lrf/core/safetensors.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

namespace {

TEST(CliLatent, TrainRenderEval) {
  lrf::test::TempDir tmp("cli_latent");
  const std::string scene = lrf::test::synthetic_scene({8, "64x48", 3, 800});
  const std::string out = tmp / "f";
  auto train = lrf::test::run_lrf("--threads 2 train '" + scene + "' --space latent --autoencoder taef2 --iters 60 "
                                  "--cache-dir '" + tmp.str() + "/cache' -o '" + out + "'");
  ASSERT_EQ(train.exit_code, 0) << train.output;
  auto config = lrf::read_json_file(out + "/config.json");
  EXPECT_EQ(config["space"], "latent");
  EXPECT_EQ(config["latent_channels"], 32);
  EXPECT_EQ(config["sh_degree"], 1);  // the latent default
  EXPECT_EQ(config["latent_range"]["min"].size(), 32u);
  // 60 steps: the short-run rates, at their largest factor, on the means and SH only.
  EXPECT_EQ(config["options"]["short_run_rates"], true);
  EXPECT_DOUBLE_EQ(config["learning_rates"]["sh_dc"].get<double>(), 4 * 2.5e-3);
  EXPECT_DOUBLE_EQ(config["learning_rates"]["position_init"].get<double>(), 4 * 1.6e-4);
  EXPECT_DOUBLE_EQ(config["learning_rates"]["opacity"].get<double>(), 5e-2);

  // A second run into the same folder is refused without --force or --resume.
  auto again = lrf::test::run_lrf("train '" + scene + "' --space latent --iters 10 -o '" + out + "'");
  EXPECT_EQ(again.exit_code, 1);
  EXPECT_NE(again.output.find("--resume"), std::string::npos) << again.output;

  auto render = lrf::test::run_lrf("render '" + out + "' --split test -o '" + tmp.str() + "/r'");
  ASSERT_EQ(render.exit_code, 0) << render.output;
  auto latent = lrf::read_safetensors(tmp / "r/view_000.safetensors");
  ASSERT_TRUE(latent.contains("latent"));
  EXPECT_EQ(latent["latent"].sizes(), (std::vector<int64_t>{32, 6, 8}));
  EXPECT_TRUE(fs::exists(tmp / "r/view_000.png"));

  auto eval = lrf::test::run_lrf("--quiet eval '" + out + "' --json");
  ASSERT_EQ(eval.exit_code, 0) << eval.output;
  auto m = nlohmann::json::parse(eval.output);
  // Without --json, a summary a person reads: units, which way is better, the autoencoder's ceiling.
  auto summary = lrf::test::run_lrf("--quiet eval '" + out + "'");
  ASSERT_EQ(summary.exit_code, 0) << summary.output;
  for (const char* needle : {"PSNR", " dB   higher is better", "round trip of these views", "FLIP", "lower is better",
                             "not computed: give --lpips-weights"})
    EXPECT_NE(summary.output.find(needle), std::string::npos) << needle << " in: " << summary.output;
  EXPECT_TRUE(m["lpips"].is_null());
  EXPECT_GT(m["roundtrip_psnr"].get<double>(), m["psnr"].get<double>() - 1.0);
  auto metrics = lrf::read_json_file(out + "/metrics.json");
  // The test images are too small for MS-SSIM's five scales: null, not a value of fewer scales.
  EXPECT_TRUE(metrics["ms_ssim"].is_null());
  EXPECT_GT(metrics["flip"].get<double>(), 0.0);
  EXPECT_LT(metrics["flip"].get<double>(), 1.0);
  for (const char* k : {"psnr", "ssim", "ms_ssim", "flip", "lpips", "lpips_reason", "roundtrip_psnr", "latent_psnr", "views", "render_fps",
                        "decode_fps", "storage_mb", "train_seconds"}) {
    EXPECT_TRUE(metrics.contains(k)) << k;
  }
  auto bad = lrf::test::run_lrf("eval '" + out + "' --scale 2");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;  // a usage error

  // --resume takes the recorded settings (space, autoencoder, SH degree...), not this command line's
  // defaults: given without --space it still continues the latent field, to the new --iters.
  auto resumed = lrf::test::run_lrf("train '" + scene + "' --resume --iters 80 --sh-degree 2 --cache-dir '" +
                                    tmp.str() + "/cache' -o '" + out + "'");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  config = lrf::read_json_file(out + "/config.json");
  EXPECT_EQ(config["space"], "latent");
  EXPECT_EQ(config["sh_degree"], 1);  // the latent default
  EXPECT_EQ(config["result"]["steps"], 80);
}

// --inria-rates keeps Inria's rates in a short run, is recorded, kept by --resume, and refused for RGB.
TEST(CliLatent, InriaRatesKeepsTheRatesOfAShortRun) {
  lrf::test::TempDir tmp("cli_latent_rates");
  const std::string scene = lrf::test::synthetic_scene({8, "64x48", 3, 800});
  const std::string out = tmp / "f", cache = " --cache-dir '" + tmp.str() + "/cache'";
  auto train = lrf::test::run_lrf("--threads 2 -q train '" + scene + "' --space latent --iters 20 --inria-rates" +
                                  cache + " -o '" + out + "'");
  ASSERT_EQ(train.exit_code, 0) << train.output;
  auto config = lrf::read_json_file(out + "/config.json");
  EXPECT_EQ(config["options"]["short_run_rates"], false);
  EXPECT_DOUBLE_EQ(config["learning_rates"]["sh_dc"].get<double>(), 2.5e-3);
  EXPECT_DOUBLE_EQ(config["learning_rates"]["position_init"].get<double>(), 1.6e-4);

  auto resumed = lrf::test::run_lrf("--threads 2 -q train '" + scene + "' --resume --iters 30" + cache + " -o '" + out + "'");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  config = lrf::read_json_file(out + "/config.json");
  EXPECT_EQ(config["result"]["steps"], 30);
  EXPECT_DOUBLE_EQ(config["learning_rates"]["sh_dc"].get<double>(), 2.5e-3);

  auto rgb = lrf::test::run_lrf("train '" + scene + "' --inria-rates --iters 10 -o '" + tmp.str() + "/rgb'");
  EXPECT_EQ(rgb.exit_code, 2);  // a usage error
  EXPECT_NE(rgb.output.find("--inria-rates"), std::string::npos) << rgb.output;
}

}  // namespace
