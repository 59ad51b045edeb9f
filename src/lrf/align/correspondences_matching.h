#pragma once
// Correspondences from lrf's own SIFT matcher, with COLMAP's two-view geometry checks.
#include <string>
#include <utility>
#include <vector>

#include "lrf/align/correspondences.h"

namespace lrf {

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

CorrespondenceSet correspondences_from_matching(const Scene& scene, const MatchOptions& options);

}  // namespace lrf
