#pragma once
// Camera paths for fly-through videos, built from a scene's training cameras:
//  - spiral: LLFF's forward-facing spiral around the mean training pose, looking at a focus point at the
//    scene's depth (for forward-facing captures such as fern);
//  - orbit: one turn around the centre of the SfM points, at the cameras' mean height and distance
//    (for object captures taken from around an object);
//  - interp: a smooth path through the training views in order (Catmull-Rom positions, slerped
//    orientations, interpolated intrinsics), passing exactly through each of them.
// Every camera has the intrinsics and image size of the first training view (interp: of the views it
// passes between).
#include <string>
#include <vector>

#include "lrf/scene/camera.h"
#include "lrf/scene/scene.h"

namespace lrf::camera_path {

enum class PathKind { spiral, orbit, interp };
// "spiral" | "orbit" | "interp"; throws lrf::Error naming the choices otherwise.
PathKind parse_path_kind(const std::string& name);
std::string path_kind_name(PathKind kind);

struct SpiralOptions {
  double rotations = 2.0;     // turns over the whole path (LLFF: 2)
  double z_rate = 0.5;        // forward/backward oscillations per turn (LLFF: 0.5)
  double radius_quantile = 0.9;  // the spiral's radii: this quantile of the cameras' offsets (LLFF: 90%)
  double focus_blend = 0.75;  // focus depth: 1 / ((1 - b) / near + b / far), LLFF's dt
};

struct PathOptions {
  int frames = 120;
  SpiralOptions spiral;
};

// What a spiral or orbit is built from; filled by describe_path so that tests and logs can see it.
struct PathGeometry {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();  // spiral: mean camera centre; orbit: the orbit's centre
  Eigen::Vector3d target = Eigen::Vector3d::Zero();  // where every camera looks (spiral, orbit)
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d radii = Eigen::Vector3d::Zero();   // spiral: along right, down, forward; orbit: (r, r, height)
  std::string source;  // how the target was found ("SfM points", "camera axes", ...)
};

// The cameras of the scene's training views (all views when it has no training split).
std::vector<Camera> training_cameras(const Scene& scene);
// The positions of the scene's SfM points.
std::vector<Eigen::Vector3d> point_positions(const Scene& scene);

// Each kind's path is built in its own file: spiral_path.h, orbit_path.h, interp_path.h.

// The path of `kind` for the scene's training cameras and SfM points. Throws lrf::Error for fewer than
// one frame or a scene whose cameras do not define the path.
// The most frames a path may have: the cameras are made up front, so an absurd count would fill the memory
// before the first frame is drawn.
constexpr int kMaxPathFrames = 100000;

std::vector<Camera> make_path(const Scene& scene, PathKind kind, const PathOptions& options,
                              PathGeometry* geometry = nullptr);

}  // namespace lrf::camera_path
