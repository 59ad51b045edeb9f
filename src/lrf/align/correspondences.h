#pragma once
// Pixel correspondences between views of a scene, for Stage I (correspondence-aware encoder
// fine-tuning): per view pair, matched pixel coordinates at the scene's resolution in use (undistorted,
// pixel centres at +0.5) and the pair's cameras. Sources: COLMAP tracks, a COLMAP database.db, or
// lrf's own SIFT matcher (each source in its own file: correspondences_database.h, correspondences_matching.h;
// the file format: correspondences_io.h).
#include <string>
#include <vector>

#include <Eigen/Core>

#include "lrf/scene/scene.h"

namespace lrf {

struct ViewPairMatches {
  int view_i = 0, view_j = 0;  // indices into the scene's views (sorted by name), i < j
  std::vector<Eigen::Vector2f> xi, xj;
};

struct CorrespondenceSet {
  std::string scene;   // scene folder it was computed on
  std::string source;  // "tracks" | "colmap-db" | "match"
  std::vector<std::string> view_names;
  std::vector<int> widths, heights;  // per view, the resolution the pixels refer to
  std::vector<ViewPairMatches> pairs;
};

// An empty set describing `scene`'s views (names and sizes), for a source to fill.
CorrespondenceSet empty_correspondences(const Scene& scene, const std::string& source);

CorrespondenceSet correspondences_from_tracks(const Scene& scene, int min_matches = 15, bool training_views_only = false);

// The view pairs the sequential matcher considers (i < j), as COLMAP's sequential matcher forms them.
std::vector<std::pair<int, int>> sequential_pairs(int views, int overlap, int quadratic_overlap);

// Distance in pixels from x_j to the epipolar line of x_i under the two views' known cameras.
double epipolar_distance(const Camera& ci, const Camera& cj, const Eigen::Vector2d& xi, const Eigen::Vector2d& xj);

struct CorrespondenceSummary {
  size_t pairs = 0, matches = 0;
  double matches_per_pair_mean = 0, matches_per_pair_median = 0;
  double epipolar_median_px = 0, epipolar_mean_px = 0;  // symmetric: mean of both directions
};
CorrespondenceSummary summarize(const CorrespondenceSet& set, const Scene& scene);

}  // namespace lrf
