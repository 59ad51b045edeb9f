#include "lrf/scene/reprojection.h"

#include <algorithm>
#include <unordered_map>

namespace lrf {

ReprojectionStats reprojection_error(const Scene& scene) {
  std::unordered_map<int64_t, Eigen::Vector3d> xyz;
  for (const auto& p : scene.points) xyz[p.id] = p.xyz;
  ReprojectionStats stats;
  std::vector<double> errors;
  for (const auto& v : scene.views) {
    for (const auto& ob : v.observations) {
      auto it = xyz.find(ob.point_id);
      if (it == xyz.end()) continue;
      Eigen::Vector2d px;
      if (!v.camera.project(it->second, &px)) {
        ++stats.behind_camera;
        continue;
      }
      errors.push_back((px - ob.pixel).norm());
    }
  }
  stats.observations = errors.size() + stats.behind_camera;
  if (errors.empty()) return stats;
  double sum = 0;
  for (double e : errors) sum += e;
  stats.mean_px = sum / errors.size();
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  stats.median_px = errors[errors.size() / 2];
  return stats;
}

}  // namespace lrf
