#pragma once
// Rays through pixel centres and where along them to sample. A ray is origin + z·direction with z the
// camera depth (the direction's component along the optical axis is 1), so near and far are planes, as
// in NeRF's LLFF setup. Samples are placed by a parameter s in [0, 1] that is uniform in disparity:
//   z(s) = 1 / ((1 − s)/near + s/far).
// Coarse samples are stratified in s (one per equal bin, jittered while training, at the bin centre when
// rendering); fine samples are drawn from the coarse weights by inverting their piecewise-constant CDF
// over the same bins (NeRF's hierarchical sampling), and both sets are rendered together, sorted.
#include <cstdint>
#include <vector>

#include "lrf/nerf/scene_bounds.h"
#include "lrf/scene/camera.h"

namespace lrf::nerf {

// Rays of every pixel of `camera` (row-major, pixel centres at +0.5): origins and directions [w·h, 3].
void camera_rays(const Camera& camera, std::vector<double>* origins, std::vector<double>* directions);
// The ray through pixel (x, y) (its centre is x + 0.5, y + 0.5).
void pixel_ray(const Camera& camera, int x, int y, double* origin, double* direction);

double depth_at(const SceneBounds& bounds, double s);

// n stratified values in [0, 1): (i + jitter_i)/n; jitter null = bin centres (0.5).
void stratified_samples(int n, const float* jitter, float* s);

// n_fine values drawn from the weights of the n_coarse equal bins of [0, 1] (bin i holds coarse sample i),
// by inverting the CDF at (k + jitter_k)/n_fine (jitter null: 0.5). Every bin keeps 1% of the mass spread
// uniformly, so a ray whose coarse pass saw nothing still samples all of its length. Output sorted.
void importance_samples(const float* coarse_weights, int n_coarse, int n_fine, const float* jitter, float* s);

// Positions in grid coordinates [n, 3] and interval lengths δ [n] (in the bounds' unit) of one ray's
// sorted samples s [n]: δ_i is the distance to the next sample, and the last interval is infinite (1e10),
// which makes the last sample an opaque backdrop as in NeRF.
void sample_points(const SceneBounds& bounds, const double* origin, const double* direction, const float* s, int n,
                   float* grid_points, float* delta);

constexpr float kLastInterval = 1e10f;

}  // namespace lrf::nerf
