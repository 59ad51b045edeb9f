#include <cstdio>
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
  // Long estimates in days, and never an overflowed hour count (a step count near 2^63 gave "-2147483648h").
  EXPECT_EQ(lrf::Progress::format_duration(3 * 86400 + 5 * 3600 + 120), "3d05h");
  EXPECT_EQ(lrf::Progress::format_duration(1e30), "more than 30 years");
}

TEST(RunInfo, JsonRoundTripAndBadJsonNamesFile) {
  fs::path path = fs::temp_directory_path() / "lrf_test_run.json";
  auto record = lrf::run_record({{"iters", 7}});
  lrf::write_json_file(path.string(), record);
  auto back = lrf::read_json_file(path.string());
  EXPECT_EQ(back["options"]["iters"], 7);
  EXPECT_TRUE(back["versions"].contains("libtorch"));
  const int lanes = back["versions"].value("compositing_lanes", 0);
  EXPECT_TRUE(lanes == 1 || lanes == 4 || lanes == 8) << lanes;
  lrf::write_file_atomic(path.string(), "{not json");
  EXPECT_THROW(lrf::read_json_file(path.string()), lrf::Error);
  fs::remove(path);
}

// The recorded commit is the checkout's HEAD (when the source is a git checkout), so that a binary
// rebuilt after a commit does not stamp its runs with the commit CMake saw when it first configured.
TEST(RunInfo, RecordsTheCommitTheBinaryWasBuiltFrom) {
  const std::string command = std::string("git -C '") + LRF_SOURCE_DIR + "' rev-parse --short=7 HEAD 2>/dev/null";
  std::string head;
  if (FILE* pipe = popen(command.c_str(), "r")) {
    char buffer[64] = {};
    if (std::fgets(buffer, sizeof buffer, pipe)) head = buffer;
    if (pclose(pipe) != 0) head.clear();
  }
  while (!head.empty() && (head.back() == '\n' || head.back() == ' ')) head.pop_back();
  const std::string recorded = lrf::version_info()["git"].get<std::string>();
  if (head.empty()) {
    EXPECT_EQ(recorded, "unknown");
    GTEST_SKIP() << "the source folder is not a git checkout";
  }
  EXPECT_TRUE(recorded == head || recorded == head + "-dirty") << "recorded " << recorded << ", HEAD " << head;
}

#include "lrf/core/npy.h"

namespace {
std::string make_npy(const std::string& dict, const std::string& data) {
  std::string header = dict;
  while ((10 + header.size() + 1) % 16) header += ' ';
  header += '\n';
  std::string out = "\x93NUMPY\x01";
  out += '\0';
  out += static_cast<char>(header.size());
  out += '\0';
  return out + header + data;
}
}  // namespace

TEST(Npy, ParsesFloat64AndFloat32AndRefusesTheRest) {
  double d[2] = {1.5, -2.25};
  auto a = lrf::parse_npy(make_npy("{'descr': '<f8', 'fortran_order': False, 'shape': (2,), }",
                                   std::string(reinterpret_cast<char*>(d), 16)),
                          "a.npy");
  EXPECT_EQ(a.shape, (std::vector<int64_t>{2}));
  EXPECT_EQ(a.data, (std::vector<double>{1.5, -2.25}));
  float f[4] = {1, 2, 3, 4};
  auto b = lrf::parse_npy(make_npy("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 2), }",
                                   std::string(reinterpret_cast<char*>(f), 16)),
                          "b.npy");
  EXPECT_EQ(b.shape, (std::vector<int64_t>{2, 2}));
  EXPECT_EQ(b.data[3], 4.0);
  auto bad = [](const std::string& dict, size_t bytes) {
    return lrf::parse_npy(make_npy(dict, std::string(bytes, '\0')), "c.npy");
  };
  EXPECT_THROW(bad("{'descr': '<f8', 'fortran_order': False, 'shape': (3,), }", 16), lrf::Error);  // short data
  EXPECT_THROW(bad("{'descr': '<i8', 'fortran_order': False, 'shape': (2,), }", 16), lrf::Error);  // dtype
  EXPECT_THROW(bad("{'descr': '<f8', 'fortran_order': True, 'shape': (2,), }", 16), lrf::Error);   // order
  EXPECT_THROW(bad("{'descr': '<f8', 'fortran_order': False, 'shape': (99999999999, 99999999999), }", 16),
               lrf::Error);  // absurd shape refused before any allocation
  EXPECT_THROW(lrf::parse_npy("not numpy", "d.npy"), lrf::Error);
}
