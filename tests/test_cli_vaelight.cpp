// `--autoencoder vaelight` through every command that takes an autoencoder, on a small synthetic scene:
// a latent field, its refinement, Stage I and Stage III, rendering, evaluation and compare. Each step must
// run and record the 4-channel autoencoder it used.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "lrf/core/run_info.h"
#include "lrf/core/safetensors.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

namespace {

std::string q(const std::string& s) { return "'" + s + "'"; }

}  // namespace

TEST(CliVaeLight, EveryCommandTakesTheFourChannelAutoencoder) {
  lrf::test::TempDir dir("cli_vaelight");
  const std::string scene = lrf::test::synthetic_scene();
  const std::string field = dir / "field", refined = dir / "refined";

  auto train = lrf::test::run_lrf("--threads 2 -q train " + q(scene) +
                                  " --space latent --autoencoder vaelight --steps 40 --cache-dir " + q(dir / "cache") + " -o " + q(field));
  ASSERT_EQ(train.exit_code, 0) << train.output;
  const auto config = lrf::read_json_file(field + "/config.json");
  EXPECT_NE(config.dump().find("vaelight"), std::string::npos) << config.dump();
  EXPECT_EQ(config["latent_channels"], 4) << config.dump();

  auto refine = lrf::test::run_lrf("--threads 2 -q refine " + q(field) + " --steps 4 -o " + q(refined));
  ASSERT_EQ(refine.exit_code, 0) << refine.output;
  // The refinement adapts the decoder's coarse layers: it writes VAElight's decoder beside the field.
  ASSERT_TRUE(fs::exists(refined + "/decoder.safetensors"));
  EXPECT_TRUE(lrf::read_safetensors(refined + "/decoder.safetensors").contains("c2v1.weight"));

  auto render = lrf::test::run_lrf("-q render " + q(refined) + " --split test -o " + q(dir / "renders"));
  ASSERT_EQ(render.exit_code, 0) << render.output;
  EXPECT_TRUE(fs::exists(dir / "renders"));
  auto eval = lrf::test::run_lrf("-q eval " + q(field));
  ASSERT_EQ(eval.exit_code, 0) << eval.output;
  EXPECT_NE(eval.output.find("PSNR"), std::string::npos) << eval.output;

  auto stage1 = lrf::test::run_lrf("--threads 2 -q finetune-encoder --scenes " + q(scene) +
                                   " --autoencoder vaelight --max-side 0 --crop 48 --steps 2 -o " + q(dir / "enc.safetensors"));
  ASSERT_EQ(stage1.exit_code, 0) << stage1.output;
  EXPECT_TRUE(lrf::read_safetensors(dir / "enc.safetensors").contains("cv14.weight"));
  auto stage3 = lrf::test::run_lrf("--threads 2 -q finetune-decoder --fields " + q(field) +
                                   " --autoencoder vaelight --crop 32 --steps 2 -o " + q(dir / "dec.safetensors"));
  ASSERT_EQ(stage3.exit_code, 0) << stage3.output;
  EXPECT_TRUE(lrf::read_safetensors(dir / "dec.safetensors").contains("c4v8.weight"));
  auto with_decoder = lrf::test::run_lrf("-q eval " + q(field) + " --decoder " + q(dir / "dec.safetensors"));
  EXPECT_EQ(with_decoder.exit_code, 0) << with_decoder.output;

  auto compare = lrf::test::run_lrf("--threads 2 -q compare " + q(scene) +
                                    " --methods latent --autoencoder vaelight --steps 20 -o " + q(dir / "compare"));
  ASSERT_EQ(compare.exit_code, 0) << compare.output;
  EXPECT_TRUE(fs::exists(dir / "compare/latent/config.json"));
}
