#pragma once
// Where a field's initial points come from. `auto`: the scene's own SfM points when it has them; else
// points triangulated from the training views with the known poses (cached, see points_cache.h); else,
// when triangulation fails or keeps fewer than min_points, random points (logged). `random` forces random
// points, `triangulate` triangulates even when the scene has points, and a file path takes a COLMAP
// points3D.bin/.txt. A few-shot scene (SceneOptions::train_views) never starts from the scene's own points
// under `auto`: they were reconstructed from every view, test views included, so its K views triangulate
// their own. A far-background shell (far_shell.h) can be added to any of them but random.
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lrf/points/far_shell.h"
#include "lrf/points/scene_triangulation.h"
#include "lrf/scene/scene.h"

namespace lrf {

struct InitPointsOptions {
  std::string mode = "auto";  // auto | random | triangulate | path of a points3D.bin/.txt
  std::string cache_dir;      // triangulation cache; "" = default_cache_dir()
  size_t min_points = 100;    // fewer triangulated points than this: random initialisation instead
  FarShellOptions shell;
  TriangulationOptions triangulation;  // training_views_only is always set: test views stay unseen
};

struct InitialPoints {
  std::vector<SfmPoint> points;  // empty: initialise randomly
  std::string source;            // "file" | "triangulated" | "random"
  std::string description;       // one line for the log
  nlohmann::json record;         // for config.json: source, file or cache entry, counts, and why random
};

// Throws lrf::Error for a bad mode or an unreadable file; a failed triangulation falls back to random.
InitialPoints choose_initial_points(const Scene& scene, const InitPointsOptions& options);

// What choose_initial_points would use, without triangulating (for `lrf scene info`): the source and a
// line that says which file or cache entry.
InitialPoints describe_initial_points(const Scene& scene, const InitPointsOptions& options);

// The track rule (fewest views per point) with which a K-view split (K = few_shot_views > 0) triangulates
// its initial points under `mode`, or nothing when that mode takes no triangulated points (random, a points
// file) or the split is the full one. Runs that reuse finished fields compare it with the rule a field
// records, so that a field started by another rule (before two-view tracks, a 3-view fern field started
// from random points) is not taken for a current one.
std::optional<int> few_shot_track_rule(const std::string& mode, int few_shot_views);

// Checks a --init-points value (auto, random, triangulate or an existing .bin/.txt file).
void check_init_points_mode(const std::string& mode);

}  // namespace lrf
