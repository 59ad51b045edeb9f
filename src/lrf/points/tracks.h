#pragma once
// Tracks from pairwise matches: the observations of one scene point across views, joined by union-find
// over (view, keypoint). A keypoint is known by its view and its exact pixel position: both of lrf's
// match sources (its SIFT matcher and a COLMAP database) give a keypoint the same coordinates in every
// pair it appears in, so a correspondence file needs no keypoint ids.
#include <vector>

#include "lrf/align/correspondences.h"
#include "lrf/points/triangulation.h"

namespace lrf {

struct Track {
  std::vector<PixelObservation> observations;  // view = scene view index; may hold two keypoints of one view
};

// Every connected set of matched keypoints, largest first (ties: by first observation), so the order
// is deterministic.
std::vector<Track> tracks_from_matches(const CorrespondenceSet& matches);

}  // namespace lrf
