// lrf eval from the command line, beyond what each field kind's own tests check.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "field_helpers.h"
#include "lrf/core/run_info.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

// A run stopped before its end has only its last checkpoint's Gaussians: eval still scores them, and says so.
TEST(CliEval, AnUnfinishedRunIsScoredWithAWarning) {
  lrf::test::TempDir dir("cli_eval_unfinished");
  const std::string field = dir / "field";
  fs::copy(lrf::test::tiny_field("rgb"), field, fs::copy_options::recursive);
  auto r = lrf::test::run_lrf("--threads 2 eval '" + field + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(r.output.find("has not finished"), std::string::npos) << r.output;
  nlohmann::json config = lrf::read_json_file(field + "/config.json");
  ASSERT_TRUE(config.contains("result"));
  config.erase("result");
  lrf::write_json_file(field + "/config.json", config);
  r = lrf::test::run_lrf("--threads 2 -q eval '" + field + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("has not finished (its config.json has no result)"), std::string::npos) << r.output;
}
