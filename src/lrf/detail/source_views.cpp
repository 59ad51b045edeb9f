#include "lrf/detail/source_views.h"

#include <algorithm>
#include <utility>

namespace lrf::detail {

std::vector<int> nearest_training_views(const Scene& scene, const Camera& camera, int count, int except) {
  const double extent = std::max(scene.camera_extent(), 1e-9);
  const Eigen::Vector3d centre = camera.center();
  const Eigen::Vector3d axis = camera.R.row(2).transpose();  // the viewing direction in world axes
  std::vector<std::pair<double, int>> ranked;
  for (int index : scene.train_indices) {
    if (index == except) continue;
    const Camera& other = scene.views[index].camera;
    const double distance = (other.center() - centre).norm() / extent;
    const double turn = 1.0 - axis.dot(other.R.row(2).transpose());
    ranked.emplace_back(distance + turn, index);
  }
  std::sort(ranked.begin(), ranked.end());
  std::vector<int> picked;
  for (int k = 0; k < count && k < static_cast<int>(ranked.size()); ++k) picked.push_back(ranked[k].second);
  return picked;
}

}  // namespace lrf::detail
