// --preset on train, compare and pipeline: the tables, their help, an explicit option winning over a preset,
// unknown names refused, the preset kept by --resume, and the expected-time line of a training run.
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "lrf/core/expected_time.h"
#include "lrf/core/run_info.h"
#include "lrf/presets/presets.h"
#include "test_helpers.h"

namespace {

using lrf::test::run_lrf;

const lrf::PresetSetting* setting_of(const lrf::Preset& preset, const std::string& option) {
  for (const auto& s : preset.settings)
    if (s.option == option) return &s;
  return nullptr;
}

TEST(Presets, EveryCommandHasQuickDefaultAndPaperAndDefaultChangesNothing) {
  for (const lrf::PresetTable* table : {&lrf::train_presets(), &lrf::compare_presets(), &lrf::pipeline_presets()}) {
    EXPECT_EQ(lrf::preset_names(*table), "quick, default, paper");
    EXPECT_TRUE(lrf::find_preset(*table, "default").settings.empty());
    EXPECT_FALSE(lrf::find_preset(*table, "quick").settings.empty());
    EXPECT_FALSE(lrf::find_preset(*table, "paper").settings.empty());
  }
}

TEST(Presets, QuickAndPaperHoldTheDocumentedValues) {
  const auto& quick = lrf::find_preset(lrf::train_presets(), "quick");
  ASSERT_NE(setting_of(quick, "--steps"), nullptr);
  EXPECT_EQ(setting_of(quick, "--steps")->value, "1500");
  ASSERT_NE(setting_of(quick, "--downscale"), nullptr);
  EXPECT_EQ(setting_of(quick, "--downscale")->value, "2");
  const auto& paper = lrf::find_preset(lrf::train_presets(), "paper");
  ASSERT_NE(setting_of(paper, "--steps"), nullptr);
  EXPECT_EQ(setting_of(paper, "--steps")->value, "30000");
  EXPECT_EQ(setting_of(lrf::find_preset(lrf::compare_presets(), "paper"), "--steps")->value, "30000");
  EXPECT_EQ(setting_of(lrf::find_preset(lrf::pipeline_presets(), "paper"), "--field-steps")->value, "30000");
  // The paper preset keeps the paper's Stage III loss; the default adds the round-trip term.
  EXPECT_EQ(setting_of(lrf::find_preset(lrf::pipeline_presets(), "paper"), "--stage3-weight-roundtrip")->value, "0");
  EXPECT_EQ(setting_of(lrf::find_preset(lrf::compare_presets(), "quick"), "--refine-steps")->value, "200");
  EXPECT_EQ(setting_of(lrf::find_preset(lrf::pipeline_presets(), "quick"), "--stage1-steps")->value, "40");
}

TEST(Presets, UnknownPresetIsAUsageErrorNamingTheValidOnes) {
  const std::string message = lrf::test::error_of([] { lrf::find_preset(lrf::train_presets(), "fast"); });
  EXPECT_NE(message.find("quick, default, paper"), std::string::npos) << message;
  lrf::test::TempDir tmp("preset_unknown");
  const std::string scene = lrf::test::synthetic_scene();
  for (const std::string& command :
       {"train '" + scene + "' -o '" + tmp / "t" + "'", "compare '" + scene + "' -o '" + tmp / "c" + "'",
        "pipeline --train-scenes '" + scene + "' --eval-scenes '" + scene + "' -o '" + tmp / "p" + "'"}) {
    auto r = run_lrf(command + " --preset fast");
    EXPECT_EQ(r.exit_code, 2) << command << "\n" << r.output;
    EXPECT_NE(r.output.find("--preset must be one of quick, default, paper, got 'fast'"), std::string::npos)
        << r.output;
    EXPECT_FALSE(std::filesystem::exists(tmp / "t")) << "nothing is done on a usage error";
  }
}

TEST(Presets, HelpListsEverySettingOfTheTable) {
  const std::pair<std::string, const lrf::PresetTable*> commands[] = {
      {"train", &lrf::train_presets()}, {"compare", &lrf::compare_presets()}, {"pipeline", &lrf::pipeline_presets()}};
  for (const auto& [command, table] : commands) {
    auto r = run_lrf(command + " --help");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    for (const auto& preset : *table) {
      EXPECT_NE(r.output.find(preset.name + ": " + preset.summary), std::string::npos) << command << " " << preset.name;
      for (const auto& s : preset.settings)
        EXPECT_NE(r.output.find(s.option + " " + s.value), std::string::npos) << command << " " << s.option;
    }
  }
}

TEST(Presets, TrainTakesThePresetsValuesUnlessGivenAndResumeKeepsThePreset) {
  lrf::test::TempDir tmp("preset_train");
  const std::string scene = lrf::test::synthetic_scene({8, "128x96", 3, 800});  // halved: lrf's 32-pixel minimum
  // --iters (the alias of --steps) given: it wins; --downscale not given: the quick preset's 2.
  const std::string out = tmp / "quick";
  auto r = run_lrf("--threads 2 train '" + scene + "' --preset quick --iters 30 --checkpoint-every 10 -o '" + out + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  auto options = lrf::read_json_file(out + "/config.json")["options"];
  EXPECT_EQ(options["preset"], "quick");
  EXPECT_EQ(options["iters"], 30);
  EXPECT_EQ(options["downscale"], 2);
  EXPECT_NE(r.output.find("64x48"), std::string::npos) << "the views at half their 128x96\n" << r.output;
  // The run said what it expected after its first 20 steps.
  EXPECT_NE(r.output.find("expected: 30 steps at "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("an estimate from the first 20 steps"), std::string::npos) << r.output;

  // Both given: the preset sets nothing.
  const std::string given = tmp / "given";
  r = run_lrf("-q train '" + scene + "' --preset quick --iters 12 --downscale 1 -o '" + given + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  options = lrf::read_json_file(given + "/config.json")["options"];
  EXPECT_EQ(options["iters"], 12);
  EXPECT_EQ(options["downscale"], 1);

  // --resume with another preset is refused, naming the recorded one; without --preset it continues.
  r = run_lrf("-q train '" + scene + "' --resume --preset paper --iters 40 -o '" + out + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("started with --preset quick"), std::string::npos) << r.output;
  r = run_lrf("-q train '" + scene + "' --resume --iters 40 -o '" + out + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  options = lrf::read_json_file(out + "/config.json")["options"];
  EXPECT_EQ(options["preset"], "quick");
  EXPECT_EQ(options["downscale"], 2);
  EXPECT_EQ(options["iters"], 40);
}

TEST(ExpectedTime, LineExtrapolatesTheMeasuredPace) {
  EXPECT_EQ(lrf::expected_time_line(30000, 20, 0.5, "training only"),
            "expected: 30000 steps at 25 ms/step \u2248 12m30s (an estimate from the first 20 steps; training only)");
  EXPECT_EQ(lrf::expected_time_line(300, 4, 10.0, ""),
            "expected: 300 steps at 2.5 s/step \u2248 12m30s (an estimate from the first 4 steps)");
  // The minutes spent before the first step (triangulating points, encoding views) count in the total.
  EXPECT_EQ(lrf::expected_time_line(300, 4, 10.0, "", 150.0),
            "expected: 300 steps at 2.5 s/step \u2248 12m30s, 15m00s in all with the 2m30s spent before the first "
            "step (an estimate from the first 4 steps)");
  EXPECT_EQ(lrf::expected_time_line(300, 4, 10.0, "", 0.4),
            "expected: 300 steps at 2.5 s/step \u2248 12m30s (an estimate from the first 4 steps)");
}

}  // namespace
