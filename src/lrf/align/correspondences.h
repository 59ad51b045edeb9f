#pragma once
// Pixel correspondences between views of a scene, for Stage I (correspondence-aware encoder
// fine-tuning): per view pair, matched pixel coordinates at the scene's resolution in use (undistorted,
// pixel centres at +0.5) and the pair's cameras. Sources: COLMAP tracks, a COLMAP database.db, or
// lrf's own SIFT matcher.
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

struct MatchOptions {
  int min_inliers = 15;          // COLMAP's two-view geometry settings used by the paper
  double min_inlier_ratio = 0.25;
  int sequential_overlap = 10;   // pair each view with the next 10 (sorted by name) ...
  int quadratic_overlap = 1;     // ... and, with quadratic overlap, with i + 2^k for k >= log2(overlap)
  double ratio_test = 0.8;       // Lowe's ratio
  double ransac_threshold_px = 1.0;
  int max_features = 8000;
  bool training_views_only = false;  // only pairs of training views (their test views stay unseen)
  // Pairs to match, as scene view indices (i < j); empty: the sequential + quadratic pairs above. Known
  // poses can say which views overlap (see points/view_pairs.h).
  std::vector<std::pair<int, int>> pairs;
};

// An empty set describing `scene`'s views (names and sizes), for a source to fill.
CorrespondenceSet empty_correspondences(const Scene& scene, const std::string& source);

CorrespondenceSet correspondences_from_tracks(const Scene& scene, int min_matches = 15, bool training_views_only = false);
CorrespondenceSet correspondences_from_database(const Scene& scene, const std::string& database_path,
                                                int min_matches = 15, bool training_views_only = false);
CorrespondenceSet correspondences_from_matching(const Scene& scene, const MatchOptions& options);

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

// Binary file: magic, JSON header (scene, source, views), then the pairs. Written atomically.
void write_correspondences(const std::string& path, const CorrespondenceSet& set);
CorrespondenceSet read_correspondences(const std::string& path);
CorrespondenceSet parse_correspondences(const std::string& bytes, const std::string& path);

}  // namespace lrf
