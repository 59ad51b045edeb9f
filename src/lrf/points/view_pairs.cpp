#include "lrf/points/view_pairs.h"

#include <algorithm>
#include <cmath>
#include <set>

namespace lrf {

std::vector<std::pair<int, int>> overlapping_view_pairs(const Scene& scene, const std::vector<int>& views,
                                                        int neighbours, double max_axis_angle_deg) {
  const double min_cos = std::cos(max_axis_angle_deg * M_PI / 180.0);
  std::set<std::pair<int, int>> pairs;
  for (int i : views) {
    const Camera& ci = scene.views[static_cast<size_t>(i)].camera;
    const Eigen::Vector3d axis_i = ci.R.row(2).transpose();  // optical axis in world coordinates
    std::vector<std::pair<double, int>> near;
    for (int j : views) {
      if (j == i) continue;
      const Camera& cj = scene.views[static_cast<size_t>(j)].camera;
      if (axis_i.dot(cj.R.row(2).transpose()) < min_cos) continue;
      near.emplace_back((ci.center() - cj.center()).norm(), j);
    }
    std::sort(near.begin(), near.end());
    for (size_t k = 0; k < near.size() && static_cast<int>(k) < neighbours; ++k) {
      pairs.insert({std::min(i, near[k].second), std::max(i, near[k].second)});
    }
  }
  return {pairs.begin(), pairs.end()};
}

}  // namespace lrf
