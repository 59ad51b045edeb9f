#include "lrf/points/cloud_distance.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "lrf/core/error.h"

namespace lrf {
namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// Nearest distance from each query point to `targets`. Exact: each query scans every target; the clouds
// compared here have tens of thousands of points, a fraction of a second in parallel.
// With `skip_self` (queries == targets) a point's own entry is left out.
std::vector<double> nearest(const std::vector<Eigen::Vector3d>& queries, const std::vector<Eigen::Vector3d>& targets,
                            bool skip_self = false) {
  std::vector<double> out(queries.size());
#pragma omp parallel for schedule(static)
  for (long q = 0; q < static_cast<long>(queries.size()); ++q) {
    double best = std::numeric_limits<double>::infinity();
    const Eigen::Vector3d& p = queries[static_cast<size_t>(q)];
    for (size_t k = 0; k < targets.size(); ++k) {
      if (!(skip_self && static_cast<long>(k) == q)) best = std::min(best, (targets[k] - p).squaredNorm());
    }
    out[static_cast<size_t>(q)] = std::sqrt(best);
  }
  return out;
}

}  // namespace

nlohmann::json CloudDistance::to_json() const {
  return {{"median_to_reference", median_to_reference},
          {"mean_to_reference", mean_to_reference},
          {"median_from_reference", median_from_reference},
          {"reference_spread", reference_spread},
          {"reference_spacing", reference_spacing}};
}

CloudDistance cloud_distance(const std::vector<Eigen::Vector3d>& cloud, const std::vector<Eigen::Vector3d>& reference) {
  if (cloud.empty() || reference.empty()) fail("cloud_distance: both clouds need points");
  CloudDistance d;
  std::vector<double> to = nearest(cloud, reference);
  d.median_to_reference = median(to);
  double sum = 0;
  for (double x : to) sum += x;
  d.mean_to_reference = sum / to.size();
  d.median_from_reference = median(nearest(reference, cloud));
  Eigen::Vector3d centre;
  for (int a = 0; a < 3; ++a) {
    std::vector<double> c;
    for (const auto& p : reference) c.push_back(p[a]);
    centre[a] = median(c);
  }
  std::vector<double> spread;
  for (const auto& p : reference) spread.push_back((p - centre).norm());
  d.reference_spread = median(spread);
  if (reference.size() > 1) d.reference_spacing = median(nearest(reference, reference, true));
  return d;
}

}  // namespace lrf
