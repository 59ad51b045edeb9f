// lrf demo: the whole method in miniature. Run through the binary at toy sizes: every stage's artefact,
// the ablation table's rows for the held-out scene (and nothing trained on it), the report and the video.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "lrf/core/run_info.h"
#include "lrf/pipeline/pipeline.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

namespace {

std::string toy_demo(const std::string& out) {
  return "--threads 2 demo -o " + out + " --autoencoder " + lrf::test::shared_dir() +
         "/models/taef2 --views 8 --size 64x48 --field-steps 30 --stage1-steps 2 --stage3-steps 2 --refine-steps 2 "
         "--video-frames 3";
}

TEST(Demo, RunsEveryStageAndJudgesOnlyTheSceneNoStageSaw) {
  lrf::test::TempDir dir("demo");
  const auto r = lrf::test::run_lrf(toy_demo(dir / "out"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const auto& row : lrf::ablation_rows()) {
    if (row == "rgb" || row == "rgb-mip") continue;  // full-resolution RGB rows are made on request only
    EXPECT_NE(r.output.find("| synthetic-held-out | " + row + " "), std::string::npos) << row << "\n" << r.output;
  }
  for (const char* f : {"config.json", "pipeline/stage1/encoder.safetensors", "pipeline/stage3/decoder-ft.safetensors",
                        "pipeline/fields/synthetic-held-out-ft-refined/config.json", "pipeline/report.html",
                        "pipeline/ablation.csv", "pipeline/stages.md"})
    EXPECT_TRUE(fs::exists(dir / ("out/" + std::string(f)))) << f;
  EXPECT_GT(fs::file_size(dir / "out/video.mp4"), 0u);

  // Stage I and Stage III learnt from the two other scenes only.
  const auto p = lrf::read_json_file(dir / "out/pipeline/pipeline.json")["options"];
  ASSERT_EQ(p["train_scenes"].size(), 2u) << p.dump();
  for (const auto& s : p["train_scenes"]) EXPECT_EQ(s.get<std::string>().find("synthetic-held-out"), std::string::npos);
  ASSERT_EQ(p["eval_scenes"].size(), 1u);
  const std::string judged = p["eval_scenes"][0];
  EXPECT_EQ(fs::path(judged).filename(), "synthetic-held-out");
  // Stage III with the round-trip term lrf recommends, not the paper's bare loss.
  for (const char* d : {"decoder-stock.json", "decoder-ft.json"})
    EXPECT_EQ(lrf::read_json_file(dir / ("out/pipeline/stage3/" + std::string(d)))["options"]["weight_roundtrip"],
              lrf::kRecommendedWeightRoundtrip)
        << d;

  // A second run refuses the finished folder rather than overwriting it.
  const auto again = lrf::test::run_lrf(toy_demo(dir / "out"));
  EXPECT_EQ(again.exit_code, 1) << again.output;
  EXPECT_NE(again.output.find("--force"), std::string::npos) << again.output;
}

TEST(Demo, RefusesTooFewViewsBeforeWritingAnything) {
  lrf::test::TempDir dir("demo_usage");
  const auto r = lrf::test::run_lrf("demo -o " + dir / "out" + " --views 3");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--views"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

}  // namespace
