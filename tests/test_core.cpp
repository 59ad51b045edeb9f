#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/core/progress.h"
#include "lrf/core/run_info.h"

namespace fs = std::filesystem;

TEST(AtomicFile, WritesWholeFileAndLeavesNoTemporary) {
  fs::path dir = fs::temp_directory_path() / "lrf_test_atomic";
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::string path = (dir / "out.txt").string();
  lrf::write_file_atomic(path, "hello");
  lrf::write_file_atomic(path, "world!");
  EXPECT_EQ(lrf::read_file(path), "world!");
  int files = 0;
  for (auto& e : fs::directory_iterator(dir)) files += e.is_regular_file();
  EXPECT_EQ(files, 1);
  fs::remove_all(dir);
}

TEST(AtomicFile, FailingWriterKeepsOldContent) {
  fs::path dir = fs::temp_directory_path() / "lrf_test_atomic2";
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::string path = (dir / "out.txt").string();
  lrf::write_file_atomic(path, "old");
  EXPECT_THROW(lrf::write_atomic_with(path,
                                      [](const std::string& tmp) {
                                        std::ofstream(tmp) << "partial";
                                        throw lrf::Error("writer failed");
                                      }),
               lrf::Error);
  EXPECT_EQ(lrf::read_file(path), "old");
  int files = 0;
  for (auto& e : fs::directory_iterator(dir)) files += e.is_regular_file();
  EXPECT_EQ(files, 1);
  fs::remove_all(dir);
}

TEST(AtomicFile, MissingFolderIsAnErrorNamingThePath) {
  try {
    lrf::write_file_atomic("/nonexistent_lrf_dir/x.txt", "x");
    FAIL() << "expected an error";
  } catch (const lrf::Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent_lrf_dir/x.txt"), std::string::npos);
  }
}

TEST(Progress, FormatsDurations) {
  EXPECT_EQ(lrf::Progress::format_duration(12.34), "12.3s");
  EXPECT_EQ(lrf::Progress::format_duration(185), "3m05s");
  EXPECT_EQ(lrf::Progress::format_duration(3720), "1h02m");
}

TEST(RunInfo, JsonRoundTripAndBadJsonNamesFile) {
  fs::path path = fs::temp_directory_path() / "lrf_test_run.json";
  auto record = lrf::run_record({{"iters", 7}});
  lrf::write_json_file(path.string(), record);
  auto back = lrf::read_json_file(path.string());
  EXPECT_EQ(back["options"]["iters"], 7);
  EXPECT_TRUE(back["versions"].contains("libtorch"));
  lrf::write_file_atomic(path.string(), "{not json");
  EXPECT_THROW(lrf::read_json_file(path.string()), lrf::Error);
  fs::remove(path);
}
