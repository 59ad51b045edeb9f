#pragma once
// Point clouds on disk: COLMAP points3D (.bin, .txt: what 3DGS tools read) and a plain .ply (x y z
// float, red green blue uchar: what viewers read). Written atomically.
#include <string>
#include <vector>

#include "lrf/points/scene_triangulation.h"
#include "lrf/scene/scene.h"

namespace lrf {

// The format follows the extension: .bin or .txt (COLMAP points3D, with each point's reprojection error)
// or .ply. Throws lrf::Error for any other extension.
void write_points_file(const std::string& path, const std::vector<TriangulatedPoint>& points);

// Reads a COLMAP points3D.bin / .txt as SfM points (for --init-points FILE).
std::vector<SfmPoint> read_points_file(const std::string& path);

}  // namespace lrf
