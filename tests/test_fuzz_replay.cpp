// Replays the fuzzers' seed corpus (written by lrf_fuzz_seeds) and every input under
// tests/fuzz_regressions/<target>/ through the same harness the fuzzers use: each must parse or be
// refused with lrf::Error, never crash. Inputs that once crashed a fuzzer live in that folder.
#include <filesystem>

#include <gtest/gtest.h>

#include "harness.h"
#include "lrf/core/atomic_file.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

namespace {

size_t replay_folder(const fs::path& dir) {
  size_t n = 0;
  for (const auto& target : lrf::fuzz::target_names()) {
    fs::path sub = dir / target;
    if (!fs::is_directory(sub)) continue;
    for (const auto& e : fs::directory_iterator(sub)) {
      if (!e.is_regular_file()) continue;
      std::string bytes = lrf::read_file(e.path().string());
      SCOPED_TRACE(e.path().string());
      EXPECT_NO_THROW(lrf::fuzz::run_target(target, reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()));
      // Every prefix too: truncation is the most common corruption.
      for (size_t cut : {bytes.size() / 3, bytes.size() / 2, bytes.size() > 0 ? bytes.size() - 1 : 0}) {
        EXPECT_NO_THROW(lrf::fuzz::run_target(target, reinterpret_cast<const uint8_t*>(bytes.data()), cut));
      }
      ++n;
    }
  }
  return n;
}

TEST(FuzzReplay, SeedCorpusParsesOrIsRefusedCleanly) {
  lrf::test::TempDir tmp("seeds");
  ASSERT_EQ(std::system((std::string(LRF_FUZZ_SEEDS_BINARY) + " " + tmp.str() + " >/dev/null 2>&1").c_str()), 0);
  EXPECT_GE(replay_folder(tmp.str()), 9u);
}

TEST(FuzzReplay, RegressionInputs) {
  fs::path dir = fs::path(LRF_SOURCE_DIR) / "tests" / "fuzz_regressions";
  if (!fs::exists(dir)) GTEST_SKIP() << "no regression inputs yet";
  replay_folder(dir);
}

}  // namespace
