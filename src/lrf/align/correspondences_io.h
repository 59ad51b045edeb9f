#pragma once
// The correspondences' file: magic, JSON header (scene, source, views), then the pairs. Written atomically.
#include <string>

#include "lrf/align/correspondences.h"

namespace lrf {

void write_correspondences(const std::string& path, const CorrespondenceSet& set);
CorrespondenceSet read_correspondences(const std::string& path);
CorrespondenceSet parse_correspondences(const std::string& bytes, const std::string& path);

}  // namespace lrf
