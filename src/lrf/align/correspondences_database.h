#pragma once
// Correspondences read from a COLMAP database.db (its two-view geometries' inlier matches).
#include <string>

#include "lrf/align/correspondences.h"

namespace lrf {

CorrespondenceSet correspondences_from_database(const Scene& scene, const std::string& database_path,
                                                int min_matches = 15, bool training_views_only = false);

}  // namespace lrf
