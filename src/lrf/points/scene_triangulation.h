#pragma once
// Points for a scene that has poses but no SfM points: match features between views that overlap
// (lrf's SIFT matcher over pose-chosen pairs, or the inlier matches of a COLMAP database.db), join the
// matches into tracks, triangulate each track with the known cameras, keep the points that pass the
// filters (reprojection error, triangulation angle, track length) and colour them from the images.
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "lrf/align/correspondences.h"
#include "lrf/align/correspondences_matching.h"
#include "lrf/scene/scene.h"

namespace lrf {

struct TriangulationOptions {
  std::string database;              // COLMAP database.db to take matches from; "" = lrf's SIFT matcher
  bool training_views_only = false;  // triangulate from the training views alone (test views stay unseen)
  int neighbours = 10;               // SIFT: each view is matched with this many nearest overlapping views
  MatchOptions match;                // SIFT, ratio test and RANSAC settings (its `pairs` are chosen here)
  double max_error_px = 2.0;         // reprojection error of every kept observation, pixels in use
  double min_angle_deg = 1.5;        // largest angle between a point's rays (COLMAP's default)
  int min_track_length = 3;          // views that agree on a point
  uint64_t seed = 0;                 // for the seed pairs of long tracks
};

struct TriangulatedPoint {
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  Eigen::Vector3f rgb = Eigen::Vector3f::Zero();  // [0, 1], mean of the observing pixels
  double error_px = 0;     // mean reprojection error over its observations
  int track_length = 0;    // observations kept (one per view)
  double angle_deg = 0;    // largest angle between its rays
};

struct TriangulationStats {
  size_t views = 0, pairs = 0, matches = 0, tracks = 0, points = 0;
  size_t too_short = 0;      // tracks rejected: fewer views than min_track_length (before or after triangulating)
  size_t inconsistent = 0;   // no two observations agree on a point in front of both cameras under the angle
  double mean_error_px = 0, median_error_px = 0;  // over every kept observation
  double mean_track_length = 0, median_angle_deg = 0;
  nlohmann::json to_json() const;
};

struct TriangulatedPoints {
  std::vector<TriangulatedPoint> points;
  TriangulationStats stats;
  std::string matches_from;  // "sift" or the database path
};

// Throws lrf::Error naming the scene (or database) when there are fewer than two views, no matches,
// or no point survives the filters, with the counts that say why.
TriangulatedPoints triangulate_scene(const Scene& scene, const TriangulationOptions& options);

// The options for triangulating from a K-view split's training views alone (K = few_shot_views > 0):
// tracks of two views are kept. Its K views are spread over the whole capture, so most surfaces are seen by
// two of them at most, and a three-view rule leaves too few points (fern, 3 views: 45 points against 173
// with two-view tracks) for anything but a random start. Other splits keep `options` as they are.
TriangulationOptions few_shot_triangulation(int few_shot_views, TriangulationOptions options);

// As SfM points (ids 1..N) for the field initialisers.
std::vector<SfmPoint> to_sfm_points(const std::vector<TriangulatedPoint>& points);

}  // namespace lrf
