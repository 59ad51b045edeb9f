// Bad input to the scene readers: each case is a one-line error naming the file, a non-zero exit code
// from the CLI, and no output.
#include <filesystem>
#include <cstring>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/scene/scene.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

namespace {

using lrf::test::run_lrf;
using lrf::test::TempDir;

// Expects `lrf scene info DIR` to fail with one error line that contains `needle`.
void expect_cli_error(const std::string& dir, const std::string& needle, const std::string& extra = "") {
  auto r = run_lrf("scene info '" + dir + "' " + extra);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find(needle), std::string::npos) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  EXPECT_EQ(r.output.rfind("error: ", 0), 0u) << r.output;
}

void copy_synthetic(const std::string& to) {
  fs::copy(lrf::test::synthetic_scene(), to, fs::copy_options::recursive);
}

TEST(SceneErrors, MissingFolder) { expect_cli_error("/nonexistent/scene", "/nonexistent/scene: scene folder not found"); }

TEST(SceneErrors, UnknownFormat) {
  TempDir tmp("unknown");
  expect_cli_error(tmp.str(), "unknown scene format");
}

TEST(SceneErrors, LlffRowCountDiffersFromImageCount) {
  TempDir tmp("llff_rows");
  std::string fern = lrf::test::scene_dir("llff-fern");
  fs::copy_file(fern + "/poses_bounds.npy", tmp / "poses_bounds.npy");
  fs::create_directories(tmp / "images_8");
  int n = 0;
  for (const auto& e : fs::directory_iterator(fern + "/images_8")) {
    if (n++ < 19) fs::create_symlink(e.path(), tmp / ("images_8/" + e.path().filename().string()));
  }
  expect_cli_error(tmp.str(), tmp / "poses_bounds.npy" + ": 20 poses but 19 images");
}

TEST(SceneErrors, CorruptNpy) {
  TempDir tmp("npy");
  fs::create_directories(tmp / "images");
  lrf::write_file_atomic(tmp / "poses_bounds.npy", "\x93NUMPY\x01\x00garbage");
  expect_cli_error(tmp.str(), "poses_bounds.npy");
}

TEST(SceneErrors, TruncatedColmapBinary) {
  TempDir tmp("truncated");
  std::string can = lrf::test::scene_dir("beer-can");
  fs::create_directories(tmp / "sparse/0");
  fs::create_directory_symlink(can + "/images", tmp / "images");
  fs::copy_file(can + "/sparse/0/cameras.bin", tmp / "sparse/0/cameras.bin");
  std::string images = lrf::read_file(can + "/sparse/0/images.bin");
  lrf::write_file_atomic(tmp / "sparse/0/images.bin", images.substr(0, images.size() / 2));
  expect_cli_error(tmp.str(), tmp / "sparse/0/images.bin" + ": truncated");
  // A count field that claims more records than the file can hold is refused before allocating.
  std::string cams = lrf::read_file(can + "/sparse/0/cameras.bin");
  uint64_t huge = 1ull << 60;
  std::memcpy(cams.data(), &huge, 8);
  lrf::write_file_atomic(tmp / "sparse/0/cameras.bin", cams);
  expect_cli_error(tmp.str(), "cameras.bin: truncated or corrupt file: claims");
}

TEST(SceneErrors, UnsupportedCameraModel) {
  TempDir tmp("fov");
  copy_synthetic(tmp / "s");
  lrf::write_file_atomic(tmp / "s/sparse/0/cameras.txt", "1 FOV 64 48 50 50 32 24 0.9\n");
  expect_cli_error(tmp / "s", "unsupported camera model FOV");
}

TEST(SceneErrors, UnreadableAndMixedSizeImages) {
  TempDir tmp("images");
  copy_synthetic(tmp / "s");
  lrf::write_file_atomic(tmp / "s/images/view_003.png", "not an image");
  cv::Mat small(10, 10, CV_8UC3, cv::Scalar(1, 2, 3));
  cv::imwrite(tmp / "s/images/view_004.png", small);
  lrf::Scene s = lrf::load_scene(tmp / "s");
  try {
    s.load_image(3);
    FAIL();
  } catch (const lrf::Error& e) {
    EXPECT_NE(std::string(e.what()).find("view_003.png: cannot decode image"), std::string::npos) << e.what();
  }
  try {
    s.load_image(4);
    FAIL();
  } catch (const lrf::Error& e) {
    EXPECT_NE(std::string(e.what()).find("view_004.png: image is 10x10, expected 64x48"), std::string::npos)
        << e.what();
  }
}

TEST(SceneErrors, SynthRefusesNonEmptyOutputAndWritesNothing) {
  TempDir tmp("synth_out");
  lrf::write_file_atomic(tmp / "keep.txt", "user data");
  auto r = run_lrf("scene synth -o '" + tmp.str() + "' --size 32x24 --views 3");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("exists and is not empty"), std::string::npos) << r.output;
  EXPECT_EQ(std::distance(fs::directory_iterator(tmp.str()), fs::directory_iterator()), 1);
  EXPECT_EQ(lrf::read_file(tmp / "keep.txt"), "user data");
}

TEST(SceneCli, InfoJsonHasTheDocumentedKeys) {
  auto r = run_lrf("--quiet scene info '" + lrf::test::scene_dir("llff-fern") + "' --images images_8 --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  auto j = nlohmann::json::parse(r.output);
  for (const char* k : {"format", "views", "train", "test", "test_indices", "width", "height", "fx", "fy", "cx", "cy",
                        "points", "points_source", "points_from", "tracks"}) {
    EXPECT_TRUE(j.contains(k)) << k;
  }
  EXPECT_EQ(j["points_source"], "file");  // fern's sparse/0/points3D.bin
  EXPECT_EQ(j["views"], 20);
  EXPECT_EQ(j["test_indices"], nlohmann::json({0, 8, 16}));
  EXPECT_NEAR(j["fx"].get<double>(), 407.566, 1e-3);
}

TEST(SceneCli, VersionAndHelp) {
  auto v = run_lrf("--version");
  EXPECT_EQ(v.exit_code, 0);
  EXPECT_NE(v.output.find("lrf 0."), std::string::npos);
  auto h = run_lrf("help scene info");
  EXPECT_EQ(h.exit_code, 0);
  EXPECT_NE(h.output.find("--test-every"), std::string::npos) << h.output;
}

}  // namespace
