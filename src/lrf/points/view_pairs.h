#pragma once
// Which views to match when the poses are known: each view with its nearest neighbours (camera centres)
// among the views that look the same way, instead of guessing from the order of the file names (a
// transforms.json lists frames in any order; DTU's snake path puts neighbours far apart by name).
#include <utility>
#include <vector>

#include "lrf/scene/scene.h"

namespace lrf {

// Pairs (i < j) of scene view indices among `views`: each view joined with its `neighbours` closest
// views whose optical axes differ by at most max_axis_angle_deg. Deterministic (ties by index).
std::vector<std::pair<int, int>> overlapping_view_pairs(const Scene& scene, const std::vector<int>& views,
                                                        int neighbours, double max_axis_angle_deg = 90.0);

}  // namespace lrf
