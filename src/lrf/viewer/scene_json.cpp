#include "lrf/viewer/scene_json.h"

#include <algorithm>
#include <set>

#include "lrf/camera_path/camera_path.h"
#include "lrf/camera_path/orbit_path.h"
#include "lrf/camera_path/pose_math.h"

namespace lrf::viewer {
namespace {

nlohmann::json vec_json(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

}  // namespace

ViewLimits view_limits(const FieldFrames& frames, int max_side) {
  const Scene& scene = frames.scene();
  ViewLimits limits;
  limits.center = scene.camera_mean();
  double radius = scene.camera_extent();
  std::vector<double> distances;
  for (const auto& p : scene.points) distances.push_back((p.xyz - limits.center).norm());
  if (!distances.empty()) radius = std::max(radius, camera_path::quantile(distances, 0.99));
  limits.radius = std::max(radius, 1e-6);
  limits.size_multiple = frames.size_multiple();
  limits.max_side = max_side;
  return limits;
}

nlohmann::json scene_json(const FieldFrames& frames, const ViewLimits& limits) {
  const Scene& scene = frames.scene();
  const auto cameras = camera_path::training_cameras(scene);
  std::string source;
  const Eigen::Vector3d target = camera_path::orbit_center(cameras, camera_path::point_positions(scene), &source);
  Eigen::Vector3d up = Eigen::Vector3d::Zero();
  for (const auto& c : cameras) up -= camera_path::camera_down(c);
  up = up.norm() > 0 ? Eigen::Vector3d(up.normalized()) : Eigen::Vector3d(-Eigen::Vector3d::UnitY());
  const std::set<int> test(scene.test_indices.begin(), scene.test_indices.end());
  const std::set<int> train(scene.train_indices.begin(), scene.train_indices.end());
  nlohmann::json views = nlohmann::json::array();
  for (size_t i = 0; i < scene.views.size(); ++i) {
    const auto& v = scene.views[i];
    const Camera& c = v.camera;
    nlohmann::json R = nlohmann::json::array();
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k) R.push_back(c.R(r, k));
    views.push_back(nlohmann::json{{"name", v.name}, {"split", test.count(int(i)) ? "test" : train.count(int(i)) ? "train" : "unused"}, {"width", c.width},
                     {"height", c.height}, {"fx", c.fx}, {"fy", c.fy}, {"cx", c.cx}, {"cy", c.cy}, {"R", R},
                     {"t", vec_json(c.t)}});
  }
  return nlohmann::json{{"space", field_kind_name(frames.kind())}, {"description", frames.describe()},
          {"size_multiple", limits.size_multiple}, {"max_side", limits.max_side}, {"center", vec_json(limits.center)},
          {"radius", limits.radius}, {"target", vec_json(target)}, {"target_source", source}, {"up", vec_json(up)},
          {"views", views}};
}

}  // namespace lrf::viewer
