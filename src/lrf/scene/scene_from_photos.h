#pragma once
// lrf scene create: from a folder of plain photos to a COLMAP scene lrf reads, by running COLMAP's
// structure-from-motion (CPU only): features, matches, mapper, then undistortion to pinhole cameras.
//
// The scene folder ends up holding images/ and sparse/0/{cameras,images,points3D}.bin (what lrf reads),
// colmap.log (COLMAP's own output) and colmap/ (the work folder: prepared photos, database, models), which
// lets a rerun skip the steps already done. sparse/ is written last, by a rename, so a run stopped midway
// never leaves a folder that lrf would take for a complete scene.
#include <string>

namespace lrf {

struct SceneFromPhotosOptions {
  std::string photos;  // the user's folder; only read
  std::string scene;   // the output folder
  int max_side = 1600;  // longer side of the photos COLMAP sees, in pixels; 0 = as taken
  std::string matcher = "auto";  // auto | exhaustive | sequential
  int exhaustive_up_to = 100;     // auto: exhaustive up to this many photos, sequential above
  std::string camera_model = "OPENCV";  // COLMAP's model for the capture's camera (undistorted at the end)
  int init_min_inliers = 100;  // verified matches of the pair the mapper starts from (COLMAP's default)
  bool force = false;  // start over, ignoring (and removing) an earlier run's work
  int threads = 0;     // COLMAP's threads; 0 = all cores
  std::string colmap = "colmap";  // the program, looked up on PATH
};

struct SceneFromPhotosResult {
  int photos = 0;
  int registered = 0;  // views in the scene
  int models = 0;      // separate models the mapper made (the largest one is kept)
  size_t points = 0;
};

// The fewest registered photos a scene is accepted with: 3, and at least half of `photos`.
int min_registered_photos(int photos);

// Throws lrf::UsageError for a bad option or output folder, lrf::Error (naming the folder or the log,
// with the log's last lines) when COLMAP is missing, fails, or registers too few photos.
SceneFromPhotosResult create_scene_from_photos(const SceneFromPhotosOptions& options);

}  // namespace lrf
