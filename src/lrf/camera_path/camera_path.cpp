#include "lrf/camera_path/camera_path.h"
#include "lrf/camera_path/interp_path.h"
#include "lrf/camera_path/orbit_path.h"
#include "lrf/camera_path/spiral_path.h"

#include "lrf/core/error.h"

namespace lrf::camera_path {

PathKind parse_path_kind(const std::string& name) {
  if (name == "spiral") return PathKind::spiral;
  if (name == "orbit") return PathKind::orbit;
  if (name == "interp") return PathKind::interp;
  fail_usage("--path must be spiral, orbit or interp (got '" + name + "')");
}

std::string path_kind_name(PathKind kind) {
  switch (kind) {
    case PathKind::spiral: return "spiral";
    case PathKind::orbit: return "orbit";
    case PathKind::interp: return "interp";
  }
  return "?";
}

std::vector<Camera> training_cameras(const Scene& scene) {
  std::vector<Camera> cameras;
  if (scene.train_indices.empty()) {
    for (const auto& v : scene.views) cameras.push_back(v.camera);
  } else {
    for (int i : scene.train_indices) cameras.push_back(scene.views.at(static_cast<size_t>(i)).camera);
  }
  return cameras;
}

std::vector<Eigen::Vector3d> point_positions(const Scene& scene) {
  std::vector<Eigen::Vector3d> points;
  points.reserve(scene.points.size());
  for (const auto& p : scene.points) points.push_back(p.xyz);
  return points;
}

std::vector<Camera> make_path(const Scene& scene, PathKind kind, const PathOptions& options, PathGeometry* geometry) {
  if (options.frames < 1 || options.frames > kMaxPathFrames) {
    fail_usage("--frames must be between 1 and " + std::to_string(kMaxPathFrames) + " (about an hour at 30 frames/s), got " +
               std::to_string(options.frames));
  }
  const auto cameras = training_cameras(scene);
  if (cameras.empty()) fail(scene.root, "the scene has no views to build a camera path from");
  const auto points = point_positions(scene);
  switch (kind) {
    case PathKind::spiral: return spiral_path(cameras, points, options, geometry);
    case PathKind::orbit: return orbit_path(cameras, points, options, geometry);
    case PathKind::interp: return interp_path(cameras, options);
  }
  fail("unknown camera path");
}

}  // namespace lrf::camera_path
