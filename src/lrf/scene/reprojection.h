#pragma once
// Geometry check: how far the SfM points land from their recorded 2D observations.
#include <cstddef>

#include "lrf/scene/scene.h"

namespace lrf {

struct ReprojectionStats {
  size_t observations = 0;
  double median_px = 0;
  double mean_px = 0;
  size_t behind_camera = 0;
};

// Reprojects every SfM point into each view that observes it (the scene's tracks) and compares with the
// stored observation, in pixels at the resolution in use. All zero when the scene has no tracks.
ReprojectionStats reprojection_error(const Scene& scene);

}  // namespace lrf
