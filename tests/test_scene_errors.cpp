// Bad input to the scene readers: each case is a one-line error naming the file, a non-zero exit code
// from the CLI, and no output.
#include <filesystem>
#include <cmath>
#include <cstring>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/scene/colmap_model.h"
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

// transforms.json's file_path is read inside the scene folder only: "../" or an absolute path was followed
// wherever it led. A folder linked into the scene still works (the other tests' scenes are built so).
TEST(SceneErrors, FilePathsOutsideTheSceneFolderAreRefused) {
  TempDir tmp("outside");
  for (const std::string& outside : {std::string("../secret/view_000.png"), std::string("/etc/hostname"),
                                     std::string("images/../../secret/view_000.png")}) {
    const std::string dir = tmp / ("s" + std::to_string(outside.size()));
    fs::create_directories(dir);
    fs::create_directory_symlink(lrf::test::synthetic_scene() + "/images", dir + "/images");
    nlohmann::json frames = nlohmann::json::array();
    for (int i = 0; i < 3; ++i) {
      frames.push_back({{"file_path", i == 2 ? outside : "images/view_00" + std::to_string(i) + ".png"},
                        {"transform_matrix", {{1, 0, 0, i}, {0, 1, 0, 0}, {0, 0, 1, 4}, {0, 0, 0, 1}}}});
    }
    lrf::write_file_atomic(dir + "/transforms.json", nlohmann::json({{"camera_angle_x", 0.8}, {"frames", frames}}).dump());
    expect_cli_error(dir, "transforms.json: file_path '" + outside + "' leads outside the scene folder");
  }
}

// A JPEG of `image` whose EXIF orientation tag says "rotate 90 degrees clockwise to view" (6), as a phone
// held upright writes it: an APP1 segment with a one-entry TIFF directory, right after the start marker.
std::string jpeg_tagged_rotate_90(const cv::Mat& image) {
  std::vector<uchar> jpeg;
  cv::imencode(".jpg", image, jpeg, {cv::IMWRITE_JPEG_QUALITY, 98});
  const unsigned char exif[] = {0xFF, 0xE1, 0x00, 0x22, 'E', 'x', 'i', 'f', 0, 0,             // APP1, 34 bytes
                                'I', 'I', 0x2A, 0x00, 0x08, 0x00, 0x00, 0x00,                 // TIFF, IFD at 8
                                0x01, 0x00,                                                   // one entry
                                0x12, 0x01, 0x03, 0x00, 0x01, 0x00, 0x00, 0x00, 0x06, 0x00, 0x00, 0x00,  // Orientation 6
                                0x00, 0x00, 0x00, 0x00};                                      // no next IFD
  std::string bytes(jpeg.begin(), jpeg.begin() + 2);
  bytes.append(reinterpret_cast<const char*>(exif), sizeof exif);
  bytes.append(jpeg.begin() + 2, jpeg.end());
  return bytes;
}

// A posed scene whose photo carries an EXIF rotation: its pixels are used as stored, as COLMAP posed them
// (it was turned upright and refused as "images of mixed sizes"); a photo read on its own is upright.
TEST(SceneErrors, ExifRotatedPhotosInAPosedSceneAreReadAsStored) {
  TempDir tmp("exif");
  copy_synthetic(tmp / "s");
  const std::string view = tmp / "s/images/view_002.png";  // decoded by its content, whatever its name
  const cv::Mat stored = cv::imread(view, cv::IMREAD_COLOR);
  ASSERT_EQ(stored.size(), cv::Size(64, 48));
  lrf::write_file_atomic(view, jpeg_tagged_rotate_90(stored));
  EXPECT_EQ(lrf::read_image_rgb(view).size(), cv::Size(48, 64));  // upright, as a viewer shows it
  EXPECT_EQ(lrf::read_image_rgb(view, lrf::ExifOrientation::as_stored).size(), cv::Size(64, 48));
  const lrf::Scene s = lrf::load_scene(tmp / "s");
  const cv::Mat loaded = s.load_image(2);
  EXPECT_EQ(loaded.size(), cv::Size(64, 48));
  // The same pixels up to JPEG's loss, not a rotated or resampled copy.
  cv::Mat original = lrf::to_float(stored);
  cv::cvtColor(original, original, cv::COLOR_BGR2RGB);
  EXPECT_LT(cv::norm(loaded, original, cv::NORM_L1) / (64.0 * 48 * 3), 0.03);
}

// A JPEG cut short decodes to mostly grey with only libjpeg's "Premature end of JPEG file" on stderr: it is
// refused naming the file; the whole JPEG still loads.
TEST(SceneErrors, TruncatedJpegIsRefusedNamingTheFile) {
  TempDir tmp("jpeg");
  cv::Mat noise(96, 128, CV_8UC3);
  cv::randu(noise, cv::Scalar::all(0), cv::Scalar::all(255));
  const std::string whole = tmp / "whole.jpg", cut = tmp / "cut.jpg";
  cv::imwrite(whole, noise);
  const std::string bytes = lrf::read_file(whole);
  lrf::write_file_atomic(cut, bytes.substr(0, bytes.size() * 2 / 3));
  EXPECT_EQ(lrf::read_image_rgb(whole).size(), cv::Size(128, 96));
  try {
    lrf::read_image_rgb(cut);
    FAIL() << "a truncated JPEG was read";
  } catch (const lrf::Error& e) {
    EXPECT_NE(std::string(e.what()).find("cut.jpg: truncated JPEG"), std::string::npos) << e.what();
  }
}

// fern's poses_bounds.npy with one number replaced, beside a link to its images_8 folder (no COLMAP model).
void fern_with_pose_value(const std::string& dir, int row, int entry, double value) {
  const std::string fern = lrf::test::scene_dir("llff-fern");
  std::string npy = lrf::read_file(fern + "/poses_bounds.npy");
  const size_t data = npy.size() - 20 * 17 * sizeof(double);  // 20 rows of 17 float64 after the header
  std::memcpy(npy.data() + data + (row * 17 + entry) * sizeof(double), &value, sizeof value);
  lrf::write_file_atomic(dir + "/poses_bounds.npy", npy);
  fs::create_directory_symlink(fern + "/images_8", dir + "/images_8");
}

// A COLMAP scene of the synthetic scene's images with `model` for its binary model.
void colmap_scene(const std::string& dir, const lrf::ColmapModel& model) {
  fs::create_directories(dir + "/sparse/0");
  fs::create_directory_symlink(lrf::test::synthetic_scene() + "/images", dir + "/images");
  lrf::write_colmap_binary(dir + "/sparse/0", model);
}

// A transforms.json scene of three of the synthetic scene's images with this horizontal field of view.
void transforms_scene(const std::string& dir, double camera_angle_x) {
  fs::create_directories(dir);
  fs::create_directory_symlink(lrf::test::synthetic_scene() + "/images", dir + "/images");
  nlohmann::json frames = nlohmann::json::array();
  for (int i = 0; i < 3; ++i) {
    frames.push_back({{"file_path", "images/view_00" + std::to_string(i) + ".png"},
                      {"transform_matrix", {{1, 0, 0, i}, {0, 1, 0, 0}, {0, 0, 1, 4}, {0, 0, 0, 1}}}});
  }
  lrf::write_file_atomic(dir + "/transforms.json",
                         nlohmann::json({{"camera_angle_x", camera_angle_x}, {"frames", frames}}).dump());
}

// A NaN or an infinity in a pose or an intrinsic is refused by every reader, naming the file, the view and
// the value (it used to load: a NaN camera position gave `extent 0.0000` and a training run that "worked").
TEST(SceneErrors, NonFinitePosesAndIntrinsicsNameTheFileTheViewAndTheValue) {
  TempDir tmp("non_finite");
  // LLFF: a training view's camera position (row 3, entry [0][3]) and a test view's focal length.
  fs::create_directories(tmp / "llff_t");
  fern_with_pose_value(tmp / "llff_t", 3, 3, std::nan(""));
  expect_cli_error(tmp / "llff_t", tmp / "llff_t/poses_bounds.npy" + ": row 3 (image003.png): camera position x is NaN");
  fs::create_directories(tmp / "llff_f");
  fern_with_pose_value(tmp / "llff_f", 8, 14, HUGE_VAL);
  expect_cli_error(tmp / "llff_f", "poses_bounds.npy: row 8 (image008.png): focal length is +infinity");

  // COLMAP (binary; the text format cannot spell NaN): a translation, then a camera parameter.
  const lrf::ColmapModel synthetic = lrf::read_colmap_model(lrf::test::synthetic_scene() + "/sparse/0");
  lrf::ColmapModel bad_pose = synthetic;
  bad_pose.images[2].tvec.y() = -HUGE_VAL;
  colmap_scene(tmp / "colmap_t", bad_pose);
  expect_cli_error(tmp / "colmap_t", tmp / "colmap_t/sparse/0/images.bin" +
                                         ": image 'view_002.png' (id 3): translation ty is -infinity");
  lrf::ColmapModel bad_camera = synthetic;
  bad_camera.cameras.begin()->second.params[0] = std::nan("");
  colmap_scene(tmp / "colmap_k", bad_camera);
  expect_cli_error(tmp / "colmap_k", "cameras.bin: camera 1 (PINHOLE): parameter 1 of 4 is NaN");
  lrf::ColmapModel zero_rotation = synthetic;
  zero_rotation.images[0].qvec.setZero();
  colmap_scene(tmp / "colmap_q", zero_rotation);
  expect_cli_error(tmp / "colmap_q", "images.bin: image 'view_000.png' (id 1): rotation quaternion is zero");

  // transforms.json (JSON cannot spell NaN either): a field of view of 0 makes the focal length infinite.
  transforms_scene(tmp / "nerf", 0);
  expect_cli_error(tmp / "nerf", tmp / "nerf/transforms.json" + ": frame 'images/view_000.png': focal length fx is +infinity");

  // Training refuses the scene as well, and leaves no output folder behind.
  auto r = run_lrf("train '" + tmp / "llff_t" + "' --images images_8 --iters 10 -o '" + tmp / "out" + "'");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("camera position x is NaN"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(tmp / "out"));
}

// Numbers that are finite but belong to no scene: a camera at 1e308 (it used to surface only as "training
// diverged"), a NaN point (it made the whole field NaN), a pose that is scaled or sheared (it trained
// without a word, on cameras that see a distorted scene). Each is refused, naming the file and the record.
TEST(SceneErrors, FarCamerasNanPointsAndNonRotationsAreRefused) {
  TempDir tmp("implausible");
  fs::create_directories(tmp / "llff_far");
  fern_with_pose_value(tmp / "llff_far", 3, 3, 1e308);
  expect_cli_error(tmp / "llff_far", "poses_bounds.npy: row 3 (image003.png): camera position x is 1e+308, beyond the +-1e9");
  // Entry [0][0] is the down axis' first component: 2 makes that column longer than 1.
  fs::create_directories(tmp / "llff_scaled");
  fern_with_pose_value(tmp / "llff_scaled", 5, 0, 2.0);
  expect_cli_error(tmp / "llff_scaled", "poses_bounds.npy: row 5 (image005.png): the pose's 3x3 block is not a rotation");

  const lrf::ColmapModel synthetic = lrf::read_colmap_model(lrf::test::synthetic_scene() + "/sparse/0");
  lrf::ColmapModel nan_point = synthetic;
  nan_point.points[7].xyz.y() = std::nan("");
  colmap_scene(tmp / "colmap_p", nan_point);
  expect_cli_error(tmp / "colmap_p",
                   "points3D.bin: point " + std::to_string(nan_point.points[7].id) + ": coordinate y is NaN");
  lrf::ColmapModel far_camera = synthetic;
  far_camera.images[1].tvec.z() = -3e12;
  colmap_scene(tmp / "colmap_far", far_camera);
  expect_cli_error(tmp / "colmap_far", "translation tz is -3e+12, beyond the +-1e9");

  // transforms.json: a camera-to-world matrix whose rotation part is scaled by 1.5.
  fs::create_directories(tmp / "nerf_scaled");
  fs::create_directory_symlink(lrf::test::synthetic_scene() + "/images", tmp / "nerf_scaled/images");
  nlohmann::json frames = nlohmann::json::array();
  for (int i = 0; i < 3; ++i) {
    const double k = i == 1 ? 1.5 : 1.0;
    frames.push_back({{"file_path", "images/view_00" + std::to_string(i) + ".png"},
                      {"transform_matrix", {{k, 0, 0, i}, {0, k, 0, 0}, {0, 0, k, 4}, {0, 0, 0, 1}}}});
  }
  lrf::write_file_atomic(tmp / "nerf_scaled/transforms.json",
                         nlohmann::json({{"camera_angle_x", 0.8}, {"frames", frames}}).dump());
  expect_cli_error(tmp / "nerf_scaled", "frame 'images/view_001.png': transform_matrix's 3x3 block is not a rotation "
                                        "(its columns have lengths 1.5, 1.5, 1.5 and its determinant is 3.375");
}

// A camera with a focal length that is not positive projects nothing: every reader refuses it, naming the
// file and the camera. The LLFF and transforms.json readers did; a negative COLMAP focal length used to be
// read, and training stopped later with the rasterizer's "render: focal lengths must be positive", no file named.
TEST(SceneErrors, NonPositiveFocalLengthsAreRefusedByEveryReader) {
  TempDir tmp("focal");
  fs::create_directories(tmp / "llff");
  fern_with_pose_value(tmp / "llff", 5, 14, -400);
  expect_cli_error(tmp / "llff", "poses_bounds.npy: row 5 has a non-positive h, w or focal");

  lrf::ColmapModel model = lrf::read_colmap_model(lrf::test::synthetic_scene() + "/sparse/0");
  model.cameras.begin()->second.params[1] = -5;
  colmap_scene(tmp / "colmap", model);
  expect_cli_error(tmp / "colmap", tmp / "colmap/sparse/0" + ": camera 1 (PINHOLE): focal length must be positive");

  transforms_scene(tmp / "nerf", -0.7);
  expect_cli_error(tmp / "nerf", tmp / "nerf/transforms.json" + ": frame 'images/view_000.png': non-positive focal length");
}

// Views smaller than kMinImageSide after --downscale are refused, naming the image and the sizes (fern at
// --downscale 1000 used to train on 1x1 images and exit 0).
TEST(SceneErrors, ImagesTooSmallAfterDownscalingAreRefused) {
  expect_cli_error(lrf::test::scene_dir("llff-fern"),
                   "image000.png: the 504x378 image is 1x1 after --downscale 1000; lrf needs at least 32 pixels per side",
                   "--images images_8 --downscale 1000");
  const std::string synthetic = lrf::test::synthetic_scene();  // 64x48
  expect_cli_error(synthetic, "view_000.png: the 64x48 image is 32x24 after --downscale 2; lrf needs at least 32",
                   "--downscale 2");
  EXPECT_EQ(run_lrf("-q scene info '" + synthetic + "'").exit_code, 0);
  TempDir tmp("too_small");
  auto r = run_lrf("train '" + synthetic + "' --downscale 2 --iters 10 -o '" + tmp / "out" + "'");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("lrf needs at least 32 pixels per side"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(tmp / "out"));
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
