// The command line's own errors: one exit-status scheme (0 done, 1 failed, 2 usage error), a mistyped
// subcommand named with the closest one, --threads validated, and --log-json honoured by parse errors too.
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "lrf/core/run_info.h"
#include "test_helpers.h"

namespace {

using lrf::test::run_lrf;

TEST(CliUsage, HelpDocumentsTheExitStatus) {
  auto r = run_lrf("--help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.output.find("Exit status: 0 done; 1 failed"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("2 usage error"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("130 stopped by Ctrl-C"), std::string::npos) << r.output;
}

TEST(CliUsage, UnknownCommandIsNamedWithTheClosestOne) {
  auto r = run_lrf("trian x");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("unknown command 'trian' (did you mean 'train'?)"), std::string::npos) << r.output;
  // After global options (and their values) too; a word far from every command gets no suggestion.
  r = run_lrf("--threads 2 -q rendr x");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("unknown command 'rendr' (did you mean 'render'?)"), std::string::npos) << r.output;
  r = run_lrf("frobnicate");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("unknown command 'frobnicate'; `lrf --help` lists the commands"), std::string::npos)
      << r.output;
}

TEST(CliUsage, ParseErrorsExitWithTwoNotCli11Codes) {
  // CLI11's own codes were 104-109: an unknown option, a missing argument, a value of the wrong type.
  for (const std::string bad : {"train", "train x -o y --no-such-option", "train x -o y --iters many", "help nosuch"}) {
    auto r = run_lrf(bad);
    EXPECT_EQ(r.exit_code, 2) << bad << "\n" << r.output;
  }
  // A command that ran and failed is 1.
  auto r = run_lrf("scene info /nonexistent/scene");
  EXPECT_EQ(r.exit_code, 1) << r.output;
}

TEST(CliUsage, NegativeThreadsAreRefused) {
  const std::string scene = lrf::test::synthetic_scene();
  for (const std::string threads : {"-1", "-8", "100000"}) {
    auto r = run_lrf("--threads " + threads + " scene info '" + scene + "'");
    EXPECT_EQ(r.exit_code, 2) << threads << "\n" << r.output;
    EXPECT_NE(r.output.find("--threads"), std::string::npos) << r.output;
  }
  auto r = run_lrf("--threads 0 -q scene info '" + scene + "'");  // 0 = all cores, as documented
  EXPECT_EQ(r.exit_code, 0) << r.output;
}

TEST(CliUsage, ParseErrorsAreJsonLinesWithLogJson) {
  for (const std::string bad : {"--log-json trian x", "--log-json train", "--log-json --threads -1 scene info x",
                                 "--log-json help nosuch"}) {
    auto r = run_lrf(bad);
    EXPECT_EQ(r.exit_code, 2) << bad << "\n" << r.output;
    ASSERT_FALSE(r.output.empty()) << bad;
    EXPECT_EQ(r.output.find('\n'), r.output.size() - 1) << "one line: " << r.output;
    nlohmann::json line;
    ASSERT_NO_THROW(line = nlohmann::json::parse(r.output)) << r.output;
    EXPECT_EQ(line["level"], "error") << r.output;
    EXPECT_FALSE(line["message"].get<std::string>().empty()) << r.output;
  }
}

}  // namespace

// A long command runs with OpenMP's passive wait unless the user chose a policy, and records it; a 1-thread
// run has no partner to wait for and keeps libgomp's default.
TEST(CliUsage, LongCommandsWaitPassivelyUnlessTheUserChose) {
  const std::string scene = lrf::test::synthetic_scene({8, "64x48", 3, 800});
  lrf::test::TempDir dir("openmp_wait");
  auto policy_of = [&](const std::string& env, const std::string& threads, const std::string& out) {
    auto r = lrf::test::run_lrf("--threads " + threads + " -q train '" + scene + "' -o '" + (dir / out) +
                                "' --iters 5");
    EXPECT_EQ(r.exit_code, 0) << env << r.output;
    return lrf::read_json_file(dir / (out + "/config.json"))["versions"]["openmp_wait_policy"].get<std::string>();
  };
  ::unsetenv("OMP_WAIT_POLICY");
  ::unsetenv("GOMP_SPINCOUNT");
  EXPECT_EQ(policy_of("unset", "2", "two"), "passive");
  EXPECT_EQ(policy_of("unset", "1", "one"), "default");
  ::setenv("OMP_WAIT_POLICY", "active", 1);
  EXPECT_EQ(policy_of("active", "2", "chosen"), "active");
  ::unsetenv("OMP_WAIT_POLICY");
}

// Training length has one name, --steps (--field-steps in pipeline and demo); the older --iters spellings
// still set the same option.
TEST(CliUsage, StepsHaveOneNameAndTheOldSpellingsAreAliases) {
  const std::string scene = lrf::test::synthetic_scene();
  lrf::test::TempDir dir("steps_alias");
  for (const char* name : {"--steps", "--iters"}) {
    const auto t = lrf::test::run_lrf("train " + scene + " -o " + dir / "out" + " " + name + " 0");
    EXPECT_EQ(t.exit_code, 2) << name << "\n" << t.output;
    EXPECT_NE(t.output.find("--steps must be at least 1"), std::string::npos) << name << "\n" << t.output;
  }
  // Past the bound, and past 2^64 (which used to be read as the largest integer): usage errors, no run.
  for (const char* steps : {"100000001", "99999999999999999999999"}) {
    const auto t = lrf::test::run_lrf("train " + scene + " -o " + dir / "big" + " --steps " + steps);
    EXPECT_EQ(t.exit_code, 2) << steps << "\n" << t.output;
    EXPECT_NE(t.output.find("--steps"), std::string::npos) << steps << "\n" << t.output;
    EXPECT_FALSE(std::filesystem::exists(dir / "big")) << steps;
  }
  // Each command's help names the option and its alias together.
  for (const auto& [cmd, names] : std::vector<std::pair<std::string, std::string>>{
           {"train", "--steps,--iters"}, {"compare", "--steps,--iters"}, {"compare", "--nerf-steps,--nerf-iters"},
           {"pipeline", "--field-steps,--field-iters"}, {"demo", "--field-steps,--iters"}}) {
    const auto help = lrf::test::run_lrf(cmd + " --help");
    EXPECT_NE(help.output.find(names), std::string::npos) << cmd << " " << names << "\n" << help.output;
  }
}
