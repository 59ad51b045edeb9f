// transforms.json (NeRF synthetic, instant-ngp, nerfstudio) parsed from text; the file-system side (which
// image a frame names, its size) is the caller's (nerf_reader.cpp), so that the parser can be fuzzed.
#include <cmath>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "lrf/core/error.h"
#include "lrf/core/finite.h"
#include "lrf/scene/transforms_json.h"

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

// A resolution beyond this is not a photograph (and would not fit in memory): refused, not allocated.
constexpr double kMaxImageSide = 1 << 16;

}  // namespace

void parse_transforms(const std::string& text, const std::string& path, const TransformsImages& images,
                      RawScene* raw, std::vector<std::string>* names) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {
    fail(path, std::string("invalid JSON: ") + e.what());
  }
  if (!j.is_object() || !j.contains("frames") || !j["frames"].is_array()) fail(path, "no \"frames\" array");
  if (j["frames"].empty()) fail(path, "\"frames\" is empty");
  std::string camera_model;
  if (j.contains("camera_model")) {
    if (!j["camera_model"].is_string()) fail(path, "\"camera_model\" is not a string");
    camera_model = j["camera_model"].get<std::string>();
  }
  for (const auto& fr : j["frames"]) {
    if (!fr.is_object() || !fr.contains("file_path") || !fr["file_path"].is_string())
      fail(path, "a frame has no \"file_path\"");
    std::string rel = fr["file_path"].get<std::string>();
    if (rel.rfind("./", 0) == 0) rel = rel.substr(2);
    if (rel.empty()) fail(path, "a frame has an empty \"file_path\"");
    if (!fr.contains("transform_matrix") || !fr["transform_matrix"].is_array() || fr["transform_matrix"].size() < 3) {
      fail(path, "frame '" + rel + "' has no 4x4 \"transform_matrix\"");
    }
    RawView v;
    v.image_rel = images.resolve(rel);
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
    const std::string frame = "frame '" + v.image_rel + "'";
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c)
        (c == 3 ? require_coordinate : require_finite)(c2w(r, c), path, frame,
                                                       "transform_matrix[" + std::to_string(r) + "][" + std::to_string(c) + "]");
    // OpenGL camera (x right, y up, z back) -> OpenCV (x right, y down, z forward).
    Eigen::Matrix3d R = c2w.topLeftCorner<3, 3>();
    require_rotation(R, path, frame, "transform_matrix's 3x3 block");
    R.col(1) *= -1;
    R.col(2) *= -1;
    set_pose_from_camera_to_world(&v.camera, R, c2w.topRightCorner<3, 1>());

    double w = number(fr, j, "w", 0), h = number(fr, j, "h", 0);
    if (!(w > 0 && h > 0)) {
      cv::Size s = images.size(v.image_rel);
      w = s.width;
      h = s.height;
    }
    if (!(w >= 1 && h >= 1 && w <= kMaxImageSide && h <= kMaxImageSide)) {
      fail(path, "image size " + std::to_string(w) + " x " + std::to_string(h) + " of '" + v.image_rel +
                     "' is not between 1 and " + std::to_string(int(kMaxImageSide)) + " pixels per side");
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
    require_finite(fx, path, frame, "focal length fx");
    require_finite(fy, path, frame, "focal length fy");
    if (!(fx > 0 && fy > 0)) fail(path, frame + ": non-positive focal length");
    v.camera.fx = fx;
    v.camera.fy = fy;
    v.camera.cx = number(fr, j, "cx", w / 2);
    v.camera.cy = number(fr, j, "cy", h / 2);
    require_finite(v.camera.cx, path, frame, "principal point cx");
    require_finite(v.camera.cy, path, frame, "principal point cy");
    const char* keys[] = {"k1", "k2", "p1", "p2", "k3", "k4"};
    for (int k = 0; k < 6; ++k) v.distortion.k[k] = number(fr, j, keys[k], 0);
    if (camera_model == "OPENCV_FISHEYE") {
      v.distortion = Distortion{};
      v.distortion.fisheye = true;
      for (int k = 0; k < 4; ++k) v.distortion.k[k] = number(fr, j, keys[k == 0 ? 0 : k == 1 ? 1 : k + 2], 0);
    }
    for (int k = 0; k < 8; ++k) require_finite(v.distortion.k[k], path, frame, "distortion coefficient " + std::to_string(k));
    if (names) names->push_back(v.name);
    raw->views.push_back(std::move(v));
  }
}

std::string common_images_dir(const std::vector<RawView>& views) {
  if (views.empty()) return "";
  auto first_component = [](const std::string& rel) {
    fs::path p(rel);
    return p.empty() ? std::string() : p.begin()->string();
  };
  const std::string first = first_component(views.front().image_rel);
  bool common = true;
  for (const auto& v : views) common = common && first_component(v.image_rel) == first;
  return common && fs::path(views.front().image_rel).has_parent_path() ? first : "";
}

}  // namespace lrf
