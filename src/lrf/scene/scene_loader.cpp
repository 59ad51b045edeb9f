// Format detection and the steps common to every format: which image folder and resolution, camera
// intrinsics at that resolution, undistorted observations, centre crop, and the train/test split.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <unordered_map>

#include <opencv2/calib3d.hpp>

#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/log.h"
#include "lrf/scene/colmap_reader.h"
#include "lrf/scene/llff_reader.h"
#include "lrf/scene/nerf_reader.h"
#include "lrf/scene/raw_scene.h"
#include "lrf/scene/undistort.h"

namespace fs = std::filesystem;

namespace lrf {

std::string find_sparse_dir(const std::string& root);

std::vector<std::string> list_images(const std::string& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return names;
  static const std::set<std::string> exts = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp"};
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    if (exts.count(ext)) names.push_back(e.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

std::string detect_scene_format(const std::string& root) {
  std::error_code ec;
  if (!fs::exists(root, ec)) fail(root, "scene folder not found");
  if (!fs::is_directory(root, ec)) fail(root, "not a folder (a scene is a folder)");
  fs::path r(root);
  std::string sparse = find_sparse_dir(root);
  bool has_images_model = !sparse.empty() && (fs::exists(fs::path(sparse) / "images.bin") ||
                                              fs::exists(fs::path(sparse) / "images.txt"));
  if (has_images_model) return "colmap";
  if (fs::exists(r / "poses_bounds.npy")) return "llff";
  if (fs::exists(r / "transforms.json") || fs::exists(r / "transforms_train.json")) return "nerf";
  fail(root, "unknown scene format: expected sparse/0/{cameras,images}.bin|.txt (COLMAP), poses_bounds.npy "
             "(LLFF) or transforms.json (NeRF / instant-ngp / nerfstudio)");
}

namespace {

// The default image folder: "images" when present, else the least downscaled images_N.
std::string default_images_dir(const std::string& root) {
  if (fs::is_directory(fs::path(root) / "images")) return "images";
  int best = 0;
  for (const auto& e : fs::directory_iterator(root)) {
    std::string n = e.path().filename().string();
    if (e.is_directory() && n.rfind("images_", 0) == 0) {
      try {
        int f = std::stoi(n.substr(7));
        if (f > 0 && (best == 0 || f < best)) best = f;
      } catch (...) {
      }
    }
  }
  if (best == 0) fail(root, "no images folder (images/ or images_N/)");
  return "images_" + std::to_string(best);
}

// Replaces the leading images folder of `rel` with `dir` ("images/a.jpg" -> "images_4/a.jpg").
std::string in_folder(const std::string& rel, const std::string& from, const std::string& to) {
  if (from == to) return rel;
  fs::path p(rel);
  if (from.empty()) return (fs::path(to) / p).string();
  fs::path rest;
  auto it = p.begin();
  if (it != p.end() && it->string() == from) ++it;
  for (; it != p.end(); ++it) rest /= *it;
  return (fs::path(to) / rest).string();
}

std::vector<int> split_test(const Scene& scene, const RawScene& raw, const SceneOptions& o) {
  std::vector<int> test;
  std::set<std::string> names;
  if (!o.test_list.empty()) {
    std::ifstream in(o.test_list);
    if (!in) fail(o.test_list, "cannot read the test list");
    std::string line;
    while (std::getline(in, line)) {
      while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
      if (!line.empty() && line[0] != '#') names.insert(line);
    }
  } else if (!raw.predefined_test.empty() && o.test_every == 8) {
    names.insert(raw.predefined_test.begin(), raw.predefined_test.end());
  }
  if (!names.empty()) {
    for (size_t i = 0; i < scene.views.size(); ++i) {
      const View& v = scene.views[i];
      std::string file = fs::path(v.name).filename().string();
      if (names.count(v.name) || names.count(file)) test.push_back(static_cast<int>(i));
    }
    if (!o.test_list.empty() && test.size() != names.size()) {
      fail(o.test_list, "lists " + std::to_string(names.size()) + " names but only " + std::to_string(test.size()) +
                            " match views of the scene");
    }
    return test;
  }
  if (o.test_every < 0) fail_usage("--test-every must be >= 0");
  if (o.test_every == 0) return test;
  for (size_t i = 0; i < scene.views.size(); i += o.test_every) test.push_back(static_cast<int>(i));
  return test;
}

// K of the n training views at positions round(j·(n-1)/(K-1)), j = 0..K-1, rounding halves to even: numpy's
// linspace(0, n-1, K).round(), which is how RegNeRF, FreeNeRF, DNGaussian and FSGS choose LLFF's few views.
std::vector<int> evenly_spaced(const std::vector<int>& train, int k, const std::string& root) {
  const int n = static_cast<int>(train.size());
  if (k > n) {
    fail(root, "--train-views " + std::to_string(k) + " asks for more training views than the split leaves (" +
                   std::to_string(n) + ")");
  }
  std::vector<int> kept;
  for (int j = 0; j < k; ++j) {
    const double position = k == 1 ? 0.0 : double(j) * double(n - 1) / double(k - 1);
    kept.push_back(train[static_cast<size_t>(std::nearbyint(position))]);  // FE_TONEAREST: halves to even
  }
  return kept;
}

}  // namespace

std::vector<Eigen::Vector2d> nominal_to_view_pixels(const View& v, const std::vector<Eigen::Vector2d>& pixels) {
  const double nx = double(v.resize_width) / v.nominal_width, ny = double(v.resize_height) / v.nominal_height;
  std::vector<Eigen::Vector2d> out;
  out.reserve(pixels.size());
  for (const auto& p : pixels) out.emplace_back(p.x() * nx, p.y() * ny);
  if (v.distortion.any()) out = undistort_points(out, v.distorted_camera, v.distortion);
  for (auto& p : out) p -= Eigen::Vector2d(v.crop_x, v.crop_y);
  return out;
}

Scene load_scene(const std::string& root, const SceneOptions& o) {
  std::string format = o.format.empty() ? detect_scene_format(root) : o.format;
  if (!fs::is_directory(root)) fail(root, "scene folder not found");
  if (o.downscale < 1) fail_usage("--downscale must be >= 1");
  std::string images_dir = o.images_dir.empty() ? default_images_dir(root) : o.images_dir;
  if (!fs::is_directory(fs::path(root) / images_dir)) fail((fs::path(root) / images_dir).string(), "image folder not found");

  RawScene raw;
  if (format == "colmap") {
    raw = read_colmap_scene(root);
  } else if (format == "llff") {
    raw = read_llff_scene(root, images_dir);
  } else if (format == "nerf") {
    raw = read_nerf_scene(root);
  } else {
    fail("unknown scene format '" + format + "' (colmap, llff or nerf)");
  }
  std::sort(raw.views.begin(), raw.views.end(), [](const RawView& a, const RawView& b) { return a.name < b.name; });
  for (size_t i = 1; i < raw.views.size(); ++i) {
    if (raw.views[i].name == raw.views[i - 1].name) fail(root, "two views share the image name " + raw.views[i].name);
  }

  Scene scene;
  scene.root = root;
  scene.format = raw.format;
  scene.points = raw.points;
  if (!raw.points.empty()) scene.points_file = raw.points_file;
  scene.has_tracks = raw.has_tracks;

  // The chosen folder's scale relative to the nominal resolution, measured on the first image; every
  // image is checked against its expected size when it is decoded.
  const RawView& first = raw.views.front();
  std::string first_path = (fs::path(root) / in_folder(first.image_rel, raw.images_dir, images_dir)).string();
  cv::Size first_size = read_image_size(first_path);
  double sx = double(first_size.width) / first.camera.width;
  double sy = double(first_size.height) / first.camera.height;
  if (std::abs(sx - sy) > 0.02 * std::max(sx, sy)) {
    fail(first_path, "image is " + std::to_string(first_size.width) + "x" + std::to_string(first_size.height) +
                         " but the camera model says " + std::to_string(first.camera.width) + "x" +
                         std::to_string(first.camera.height) + " (aspect ratios differ)");
  }

  for (const RawView& rv : raw.views) {
    View v;
    v.name = rv.name;
    v.image_path = (fs::path(root) / in_folder(rv.image_rel, raw.images_dir, images_dir)).string();
    v.file_width = static_cast<int>(std::lround(rv.camera.width * sx));
    v.file_height = static_cast<int>(std::lround(rv.camera.height * sy));
    v.resize_width = std::max(1, static_cast<int>(std::lround(double(v.file_width) / o.downscale)));
    v.resize_height = std::max(1, static_cast<int>(std::lround(double(v.file_height) / o.downscale)));
    v.distortion = rv.distortion;
    v.distorted_camera = rv.camera.resized(v.resize_width, v.resize_height);
    int w = v.resize_width, h = v.resize_height;
    if (o.crop_to_multiple_of_8) {
      v.crop_x = (w % 8) / 2;
      v.crop_y = (h % 8) / 2;
      w -= w % 8;
      h -= h % 8;
    }
    if (w < kMinImageSide || h < kMinImageSide) {
      const std::string after = "--downscale " + std::to_string(o.downscale) +
                                (o.crop_to_multiple_of_8 ? " and the crop to multiples of 8" : "");
      fail(v.image_path, "the " + std::to_string(v.file_width) + "x" + std::to_string(v.file_height) + " image is " +
                             std::to_string(w) + "x" + std::to_string(h) + " after " + after + "; lrf needs at least " +
                             std::to_string(kMinImageSide) + " pixels per side (use a smaller --downscale or a larger "
                             "image folder)");
    }
    v.camera = v.distorted_camera.cropped(v.crop_x, v.crop_y, w, h);
    v.nominal_width = rv.camera.width;
    v.nominal_height = rv.camera.height;
    std::vector<Eigen::Vector2d> pix;
    pix.reserve(rv.observations.size());
    for (const auto& ob : rv.observations) pix.push_back(ob.pixel);
    pix = nominal_to_view_pixels(v, pix);
    for (size_t k = 0; k < pix.size(); ++k) v.observations.push_back({pix[k], rv.observations[k].point_id});
    scene.views.push_back(std::move(v));
  }

  scene.test_indices = split_test(scene, raw, o);
  std::set<int> test(scene.test_indices.begin(), scene.test_indices.end());
  for (int i = 0; i < static_cast<int>(scene.views.size()); ++i) {
    if (!test.count(i)) scene.train_indices.push_back(i);
  }
  if (scene.train_indices.empty()) fail(root, "no training views left after the train/test split");
  if (o.train_views < 0) fail_usage("--train-views must be >= 0");
  if (o.train_views > 0) {
    scene.train_indices = evenly_spaced(scene.train_indices, o.train_views, root);
    scene.few_shot_views = o.train_views;
  }
  return scene;
}

}  // namespace lrf
