#pragma once
// How close two point clouds of the same scene are (e.g. lrf's triangulation and COLMAP's points, in the
// same frame because they share the poses): nearest-neighbour distances from each cloud to the other.
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace lrf {

struct CloudDistance {
  double median_to_reference = 0, mean_to_reference = 0;  // each point of `cloud` to its nearest reference point
  double median_from_reference = 0;                        // each reference point to its nearest cloud point
  double reference_spread = 0;   // median distance of the reference points from their median (the scale)
  double reference_spacing = 0;  // median distance of a reference point to its nearest other one: the
                                 // distance a point exactly on the reference's surface is expected to have
  nlohmann::json to_json() const;
};

// Exact nearest neighbours (brute force, parallel). Throws lrf::Error if a cloud is empty.
CloudDistance cloud_distance(const std::vector<Eigen::Vector3d>& cloud, const std::vector<Eigen::Vector3d>& reference);

}  // namespace lrf
