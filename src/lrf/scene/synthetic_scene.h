#pragma once
// The built-in synthetic scene: a textured sphere, a box and a small sphere on a checkered ground inside a
// textured dome, ray-traced (2x2 supersampled, Lambertian) from cameras on a ring around it. Written as a
// COLMAP text model with images, SfM points sampled on the surfaces (with their colours) and tracks (each
// point's visible projections), so every reader path and the tests have a scene with exact geometry.
#include <string>

#include <vector>

#include <Eigen/Core>

#include "lrf/scene/camera.h"

namespace lrf {

struct SyntheticOptions {
  int views = 24;
  std::string size = "256x192";
  unsigned seed = 0;
  int points = 4000;
};

// The cameras of the synthetic scene (deterministic in the options), as written by write_synthetic_scene.
std::vector<Camera> synthetic_cameras(const SyntheticOptions& options);

void write_synthetic_scene(const std::string& dir, const SyntheticOptions& options);

// The scene's radiance along a ray (exposed for tests): colour of the first surface hit, and its distance.
Eigen::Vector3d synthetic_trace(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, unsigned seed,
                                double* distance = nullptr);

}  // namespace lrf
