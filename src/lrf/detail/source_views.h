#pragma once
// Which training photographs a novel view borrows from: the ones whose cameras stand nearest to it and
// look the most alike, as image-based rendering picks them.
#include <vector>

#include "lrf/scene/scene.h"

namespace lrf::detail {

// Up to `count` of the scene's training views (indices into scene.views, never a test view), nearest
// first by the distance of the camera centres in units of the scene extent plus (1 - cos) of the angle
// between the viewing directions. `except` (a view index, -1 = none) is never picked: a training view that
// stands in for a novel one must not borrow from itself.
std::vector<int> nearest_training_views(const Scene& scene, const Camera& camera, int count, int except = -1);

}  // namespace lrf::detail
