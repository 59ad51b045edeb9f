#pragma once
// The far background of unbounded captures (sky, distant walls) is seldom triangulated: too far for
// parallax, or too plain for features. 3DGS then has nothing there to start from and densification grows
// into it slowly from the foreground. A shell of points around the scene, beyond its points, gives every
// background pixel something to start from: points on a sphere (Fibonacci lattice, nearly uniform), kept
// where a training view sees them, coloured by the mean of the training pixels they project to.
#include <vector>

#include "lrf/scene/scene.h"

namespace lrf {

struct FarShellOptions {
  int points = 0;               // lattice points on the sphere (0: no shell); only the seen ones are kept
  double radius_factor = 2.0;   // radius = factor x max(97th percentile distance of the points, farthest camera)
};

// Shell points for `scene` around the median of `points` (the camera mean without points), from the
// training views.
std::vector<SfmPoint> far_shell_points(const Scene& scene, const std::vector<SfmPoint>& points,
                                       const FarShellOptions& options);

}  // namespace lrf
