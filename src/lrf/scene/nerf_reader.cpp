#include <cmath>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/run_info.h"
#include "lrf/scene/raw_scene.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace lrf {
namespace {

// Intrinsics may be given per file or per frame (nerfstudio); a frame's value wins.
double number(const json& frame, const json& file, const char* key, double fallback) {
  if (frame.contains(key) && frame[key].is_number()) return frame[key].get<double>();
  if (file.contains(key) && file[key].is_number()) return file[key].get<double>();
  return fallback;
}

bool has(const json& frame, const json& file, const char* key) {
  return (frame.contains(key) && frame[key].is_number()) || (file.contains(key) && file[key].is_number());
}

std::string resolve_image(const std::string& root, const std::string& base_dir, std::string rel,
                          const std::string& json_path) {
  if (rel.rfind("./", 0) == 0) rel = rel.substr(2);
  fs::path p = fs::path(base_dir) / rel;
  if (!p.has_extension() || !fs::exists(fs::path(root) / p)) {
    // The NeRF synthetic scenes list "./train/r_0" without the extension.
    for (const char* ext : {".png", ".jpg", ".jpeg", ".JPG", ".PNG"}) {
      fs::path q = p;
      q += ext;
      if (fs::exists(fs::path(root) / q)) return q.lexically_normal().string();
    }
  }
  if (!fs::exists(fs::path(root) / p)) fail(json_path, "image '" + rel + "' not found under " + root);
  return p.lexically_normal().string();
}

void read_transforms(const std::string& root, const std::string& file, RawScene* raw, std::vector<std::string>* names) {
  std::string path = (fs::path(root) / file).string();
  json j = read_json_file(path);
  if (!j.contains("frames") || !j["frames"].is_array()) fail(path, "no \"frames\" array");
  if (j["frames"].empty()) fail(path, "\"frames\" is empty");
  for (const auto& fr : j["frames"]) {
    if (!fr.contains("file_path") || !fr["file_path"].is_string()) fail(path, "a frame has no \"file_path\"");
    if (!fr.contains("transform_matrix") || !fr["transform_matrix"].is_array() || fr["transform_matrix"].size() < 3) {
      fail(path, "frame '" + fr["file_path"].get<std::string>() + "' has no 4x4 \"transform_matrix\"");
    }
    RawView v;
    v.image_rel = resolve_image(root, "", fr["file_path"].get<std::string>(), path);
    v.name = v.image_rel;
    Eigen::Matrix4d c2w = Eigen::Matrix4d::Identity();
    for (int r = 0; r < 3; ++r) {
      const auto& row = fr["transform_matrix"][r];
      if (!row.is_array() || row.size() != 4) fail(path, "transform_matrix rows must have 4 numbers");
      for (int c = 0; c < 4; ++c) {
        if (!row[c].is_number()) fail(path, "transform_matrix holds a non-number");
        c2w(r, c) = row[c].get<double>();
      }
    }
    if (!c2w.allFinite()) fail(path, "transform_matrix of '" + v.image_rel + "' is not finite");
    // OpenGL camera (x right, y up, z back) -> OpenCV (x right, y down, z forward).
    Eigen::Matrix3d R = c2w.topLeftCorner<3, 3>();
    R.col(1) *= -1;
    R.col(2) *= -1;
    set_pose_from_camera_to_world(&v.camera, R, c2w.topRightCorner<3, 1>());

    double w = number(fr, j, "w", 0), h = number(fr, j, "h", 0);
    if (w <= 0 || h <= 0) {
      cv::Size s = read_image_size((fs::path(root) / v.image_rel).string());
      w = s.width;
      h = s.height;
    }
    v.camera.width = static_cast<int>(std::lround(w));
    v.camera.height = static_cast<int>(std::lround(h));
    double fx;
    if (has(fr, j, "fl_x")) {
      fx = number(fr, j, "fl_x", 0);
    } else if (has(fr, j, "camera_angle_x")) {
      fx = 0.5 * w / std::tan(0.5 * number(fr, j, "camera_angle_x", 0));
    } else {
      fail(path, "no focal length (\"fl_x\" or \"camera_angle_x\")");
    }
    double fy = fx;
    if (has(fr, j, "fl_y")) {
      fy = number(fr, j, "fl_y", fx);
    } else if (has(fr, j, "camera_angle_y")) {
      fy = 0.5 * h / std::tan(0.5 * number(fr, j, "camera_angle_y", 0));
    }
    if (!(fx > 0 && fy > 0)) fail(path, "non-positive focal length");
    v.camera.fx = fx;
    v.camera.fy = fy;
    v.camera.cx = number(fr, j, "cx", w / 2);
    v.camera.cy = number(fr, j, "cy", h / 2);
    const char* keys[] = {"k1", "k2", "p1", "p2", "k3", "k4"};
    for (int k = 0; k < 6; ++k) v.distortion.k[k] = number(fr, j, keys[k], 0);
    if (j.value("camera_model", std::string()) == "OPENCV_FISHEYE") {
      v.distortion = Distortion{};
      v.distortion.fisheye = true;
      for (int k = 0; k < 4; ++k) v.distortion.k[k] = number(fr, j, keys[k == 0 ? 0 : k == 1 ? 1 : k + 2], 0);
    }
    if (names) names->push_back(v.name);
    raw->views.push_back(std::move(v));
  }
}

}  // namespace

RawScene read_nerf_scene(const std::string& root) {
  RawScene raw;
  raw.format = "nerf";
  if (fs::exists(fs::path(root) / "transforms.json")) {
    read_transforms(root, "transforms.json", &raw, nullptr);
  } else {
    // NeRF synthetic layout: the split is given by the files.
    read_transforms(root, "transforms_train.json", &raw, nullptr);
    if (fs::exists(fs::path(root) / "transforms_test.json")) {
      read_transforms(root, "transforms_test.json", &raw, &raw.predefined_test);
    }
  }
  // The images folder is the common first path component of the frames' files (usually "images").
  std::string first = fs::path(raw.views.front().image_rel).begin()->string();
  bool common = true;
  for (const auto& v : raw.views) common = common && fs::path(v.image_rel).begin()->string() == first;
  raw.images_dir = common && fs::path(raw.views.front().image_rel).has_parent_path() ? first : "";
  return raw;
}

}  // namespace lrf
