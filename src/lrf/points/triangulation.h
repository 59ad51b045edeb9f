#pragma once
// Multi-view triangulation of one 3D point from its pixel observations in views with known cameras:
// the linear (DLT) solution in normalised camera coordinates, refined by Gauss-Newton on the pixel
// reprojection error, and a robust version that picks the observations that agree (a track built from
// pairwise matches can hold a wrong match, or two keypoints in one view).
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "lrf/scene/camera.h"

namespace lrf {

struct PixelObservation {
  int view = 0;            // index into the camera list the caller passes
  Eigen::Vector2d pixel;   // lrf pixels: centres at +0.5, at the camera's resolution
};

// Linear least-squares point from >= 2 observations (rows x·P3 − P1, y·P3 − P2 of each normalised
// camera [R|t], solved by SVD). Returns false when the system is degenerate (parallel rays, or the
// solution at infinity).
bool triangulate_linear(const std::vector<Camera>& cameras, const std::vector<PixelObservation>& obs,
                        Eigen::Vector3d* point);

// A few Gauss-Newton steps on the sum of squared pixel reprojection errors, from `point`.
void refine_point(const std::vector<Camera>& cameras, const std::vector<PixelObservation>& obs, Eigen::Vector3d* point,
                  int iterations = 5);

// Pixel distance between an observation and the point's projection; +inf behind the camera.
double reprojection_error(const Camera& camera, const Eigen::Vector3d& point, const Eigen::Vector2d& pixel);

// The largest angle (degrees) between the rays from the observing cameras' centres to the point.
double max_triangulation_angle_deg(const std::vector<Camera>& cameras, const std::vector<PixelObservation>& obs,
                                   const Eigen::Vector3d& point);

struct RobustTriangulationOptions {
  double max_error_px = 2.0;    // an observation agrees with the point within this reprojection error
  double min_angle_deg = 1.5;   // seed pairs must see the point under at least this angle (COLMAP's default)
  int max_seed_pairs = 200;     // every pair when a track has fewer; else this many, drawn with `seed`
  uint64_t seed = 0;
};

struct RobustPoint {
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  std::vector<PixelObservation> inliers;  // at most one per view
  double mean_error_px = 0;
  double angle_deg = 0;  // max_triangulation_angle_deg over the inliers
};

// Triangulates from every pair of observations in different views that sees the point under
// min_angle_deg (in front of both cameras), keeps the pair whose point most observations agree with
// (one per view, the closest), then re-solves and refines on those. False when no pair qualifies.
bool triangulate_robust(const std::vector<Camera>& cameras, const std::vector<PixelObservation>& obs,
                        const RobustTriangulationOptions& options, RobustPoint* out);

}  // namespace lrf
