#include "harness.h"

#include <filesystem>
#include <stdexcept>

#include "lrf/align/correspondences.h"
#include "lrf/align/correspondences_io.h"
#include "lrf/core/error.h"
#include "lrf/core/npy.h"
#include "lrf/scene/colmap_model.h"
#include "lrf/scene/transforms_json.h"
#include "lrf/scene/scene_spec.h"

namespace lrf::fuzz {
namespace {

// The first byte picks which of the three COLMAP files the rest is parsed as.
void colmap(const std::string& bytes, bool text) {
  if (bytes.empty()) return;
  std::string body = bytes.substr(1);
  switch (static_cast<unsigned char>(bytes[0]) % 3) {
    case 0:
      for (const auto& [id, cam] : parse_colmap_cameras(body, "fuzz", text)) {
        double fx, fy, cx, cy;
        Distortion d;
        try {
          colmap_intrinsics(cam, "fuzz", &fx, &fy, &cx, &cy, &d);
        } catch (const Error&) {
        }
      }
      break;
    case 1:
      parse_colmap_images(body, "fuzz", text);
      break;
    default:
      parse_colmap_points(body, "fuzz", text);
  }
}

// transforms.json with a stand-in file system: every named image exists, at 64 x 48 pixels.
void transforms(const std::string& bytes) {
  TransformsImages images;
  images.resolve = [](const std::string& rel) {
    std::string p = std::filesystem::path(rel).lexically_normal().string();
    if (p.empty()) throw std::logic_error("parse_transforms passed an empty file_path");
    return p;
  };
  images.size = [](const std::string&) { return cv::Size(64, 48); };
  RawScene raw;
  std::vector<std::string> names;
  parse_transforms(bytes, "fuzz", images, &raw, &names);
  if (raw.views.empty() || names.size() != raw.views.size()) throw std::logic_error("parse_transforms: no views");
  common_images_dir(raw.views);
}

// A scene argument of lrf pipeline (PATH[:--images=DIR][:--downscale=N]). What it accepts must be what it
// writes back: the path and options, written as the records write them, parse to the same scene.
void scene_spec(const std::string& bytes) {
  const SceneSpec s = parse_scene_spec(bytes);
  if (s.path.empty()) throw std::logic_error("parse_scene_spec accepted an empty path");
  if (s.resolution.downscale < 0 || s.resolution.downscale > kMaxSceneDownscale)
    throw std::logic_error("parse_scene_spec accepted --downscale " + std::to_string(s.resolution.downscale));
  const std::string again = s.resolution.is_default() ? s.path : s.path + ":" + s.resolution.text();
  const SceneSpec t = parse_scene_spec(again);
  if (t.path != s.path || t.resolution.json() != s.resolution.json())
    throw std::logic_error("parse_scene_spec: '" + again + "' does not read back as it was written");
}

}  // namespace

const std::vector<std::string>& plain_target_names() {
  static const std::vector<std::string> names = {"colmap_bin", "colmap_txt", "npy", "correspondences", "transforms",
                                                 "scene_spec"};
  return names;
}

bool run_plain_target(const std::string& target, const std::string& bytes) {
  if (target == "colmap_bin") {
    colmap(bytes, false);
  } else if (target == "colmap_txt") {
    colmap(bytes, true);
  } else if (target == "npy") {
    parse_npy(bytes, "fuzz");
  } else if (target == "correspondences") {
    parse_correspondences(bytes, "fuzz");
  } else if (target == "transforms") {
    transforms(bytes);
  } else if (target == "scene_spec") {
    scene_spec(bytes);
  } else {
    return false;
  }
  return true;
}

}  // namespace lrf::fuzz
