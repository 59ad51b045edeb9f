#pragma once
// Triangulated points are computed once per state of the scene and kept beside the latent cache, never in
// the scene folder: <cache>/points/<hash>.bin (COLMAP points3D) and <hash>.json (the key, the counts, or
// why triangulation failed: a failure is remembered too, so every method of a comparison falls back at
// once). The key lists what the points depend on: the scene folder, each participating view's image file
// (path, size, modification time), camera (intrinsics, pose, distortion) and resolution/crop, the match
// source, and the triangulation options.
#include <string>

#include "lrf/points/scene_triangulation.h"

namespace lrf {

struct CachedTriangulation {
  std::vector<TriangulatedPoint> points;  // empty when triangulation failed
  std::string failure;                    // the lrf::Error text when it failed
  nlohmann::json stats;                   // TriangulationStats::to_json() of the run that made the entry
  std::string path;                       // the entry's .json file
  bool hit = false;                       // read from the cache rather than computed now
};

std::string triangulation_cache_key(const Scene& scene, const TriangulationOptions& options);
// The entry's .json path for this key inside cache_dir.
std::string triangulation_cache_path(const std::string& cache_dir, const std::string& key);

// Reads the entry if its recorded key matches, else triangulates and writes it (atomically). A failure of
// triangulate_scene (lrf::Error) is returned in `failure`, not thrown.
CachedTriangulation triangulate_cached(const Scene& scene, const TriangulationOptions& options,
                                       const std::string& cache_dir);

// The entry for this scene and options if one exists (no triangulation); hit = false when there is none.
CachedTriangulation find_cached_triangulation(const Scene& scene, const TriangulationOptions& options,
                                              const std::string& cache_dir);

}  // namespace lrf
