#pragma once
// The reference triangulation: COLMAP's point_triangulator on the scene's known poses (its features,
// matches over the same pose-chosen view pairs, its track building, triangulation and bundle adjustment
// of the points with the cameras held fixed). lrf writes the views undistorted at the resolution in use
// with their pinhole cameras into a work folder, so both triangulations see the same images and cameras.
#include <string>

#include "lrf/points/scene_triangulation.h"
#include "lrf/scene/colmap_program.h"  // colmap_available

namespace lrf {

struct ColmapTriangulationOptions {
  std::string colmap = "colmap";  // the program (found on PATH)
  std::string work_dir;           // "" = a fresh folder under the system's temporary folder, removed after
  int threads = 0;                // 0 = COLMAP's default (all cores)
};

// Throws lrf::Error when COLMAP is missing, a step fails (naming the step and its log file), or it
// triangulates no point. Uses options.training_views_only, neighbours and max_features of `t`.
TriangulatedPoints triangulate_with_colmap(const Scene& scene, const TriangulationOptions& t,
                                           const ColmapTriangulationOptions& options);

}  // namespace lrf
