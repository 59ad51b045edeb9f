// Replays the fuzzers' seed corpus (written by lrf_fuzz_seeds) and every input under
// tests/fuzz_regressions/<target>/ through the same harness the fuzzers use: each must parse or be
// refused with lrf::Error, never crash. Inputs that once crashed a fuzzer live in that folder.
#include <filesystem>

#include <gtest/gtest.h>

#include "harness.h"
#include "lrf/core/atomic_file.h"
#include "lrf/core/pickle.h"
#include "lrf/core/run_info.h"
#include "lrf/core/safetensors.h"
#include "lrf/core/torch_zip.h"
#include "lrf/latent/latent_config.h"
#include "lrf/splat/ply_io.h"
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

// The seeds of the tensor formats are real files of their format (a fuzzer starting from refused inputs
// would explore little): each parses, with the content the seed writer put in.
TEST(FuzzReplay, TensorFormatSeedsAreAccepted) {
  lrf::test::TempDir tmp("seeds_ok");
  ASSERT_EQ(std::system((std::string(LRF_FUZZ_SEEDS_BINARY) + " " + tmp.str() + " >/dev/null 2>&1").c_str()), 0);
  auto seed = [&](const std::string& rel) { return lrf::read_file(tmp / rel); };
  auto sd = lrf::parse_torch_state_dict(seed("torch_zip/state_dict.pth"), "state_dict.pth");
  ASSERT_EQ(sd.size(), 4u);
  EXPECT_TRUE(torch::equal(sd["conv.weight"], torch::arange(6, torch::kFloat).reshape({2, 3})));
  EXPECT_TRUE(torch::equal(sd["conv.weight_t"], sd["conv.weight"].reshape({6}).as_strided({2, 2}, {1, 3}, 1)));
  EXPECT_EQ(sd["scalar"].dim(), 0);
  EXPECT_EQ(sd["scalar"].item<float>(), 2.0f);
  EXPECT_EQ(lrf::parse_safetensors(seed("safetensors/dtypes.safetensors"), "s").size(), 5u);
  EXPECT_EQ(lrf::splat::parse_ply(seed("ply/c3_sh1.ply"), "p", 3).size(), 3);
  EXPECT_EQ(lrf::splat::parse_ply(seed("ply/c4_sh0.ply"), "p", 4).max_sh_degree, 0);
  EXPECT_EQ(lrf::splat::parse_field_config(nlohmann::json::parse(seed("field_config/rgb.json")), "c").kind, lrf::FieldKind::rgb);
  EXPECT_EQ(lrf::parse_latent_config(nlohmann::json::parse(seed("field_config/latent.json")), "c").range.channels(), 4);
  EXPECT_EQ(lrf::parse_latent_config(nlohmann::json::parse(seed("field_config/feature.json")), "c").feature_dim, 2);
  EXPECT_NE(lrf::test::error_of([&] {
              lrf::pickle::unpickle(seed("pickle/evil_os_system.pkl"), "evil", nullptr);
            }).find("refusing pickle global 'os.system'"),
            std::string::npos);
}

TEST(FuzzReplay, RegressionInputs) {
  fs::path dir = fs::path(LRF_SOURCE_DIR) / "tests" / "fuzz_regressions";
  if (!fs::exists(dir)) GTEST_SKIP() << "no regression inputs yet";
  replay_folder(dir);
}

}  // namespace
