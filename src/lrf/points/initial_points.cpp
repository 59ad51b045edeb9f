#include "lrf/points/initial_points.h"

#include <algorithm>
#include <filesystem>
#include <optional>

#include "lrf/core/cache_key.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/points/points_cache.h"
#include "lrf/points/points_file.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

bool is_keyword(const std::string& mode) { return mode == "auto" || mode == "random" || mode == "triangulate"; }

// Where `mode` takes a split's points from. A split of K views (K > 0) never takes the scene's own points
// under auto: they were reconstructed from every view, test views included.
enum class Source { kRandom, kFile, kScenePoints, kTriangulation };

Source source_of(const std::string& mode, int few_shot_views, bool scene_has_points) {
  if (mode == "random") return Source::kRandom;
  if (!is_keyword(mode)) return Source::kFile;
  if (mode == "auto" && scene_has_points && few_shot_views == 0) return Source::kScenePoints;
  return Source::kTriangulation;
}

Source source_of(const Scene& scene, const InitPointsOptions& o) {
  return source_of(o.mode, scene.few_shot_views, !scene.points.empty());
}

std::string cache_dir_of(const InitPointsOptions& o) { return o.cache_dir.empty() ? default_cache_dir() : o.cache_dir; }

// Automatic initialisation sees the training views only, as the field does: test views stay unseen.
TriangulationOptions for_training(const Scene& scene, const InitPointsOptions& o) {
  TriangulationOptions t = o.triangulation;
  t.training_views_only = true;
  return few_shot_triangulation(scene.few_shot_views, t);
}

InitialPoints random_because(const std::string& why) {
  InitialPoints ip;
  ip.source = "random";
  ip.description = "random points (" + why + ")";
  ip.record = {{"source", "random"}, {"reason", why}};
  return ip;
}

std::string absolute(const std::string& path) { return fs::absolute(path).lexically_normal().string(); }

void add_shell(const Scene& scene, const InitPointsOptions& o, InitialPoints* ip) {
  if (o.shell.points <= 0 || ip->points.empty()) return;
  std::vector<SfmPoint> shell = far_shell_points(scene, ip->points, o.shell);
  int64_t next_id = 0;
  for (const auto& p : ip->points) next_id = std::max(next_id, p.id);
  for (auto& p : shell) p.id = ++next_id;
  ip->record["far_shell"] = {{"lattice_points", o.shell.points}, {"radius_factor", o.shell.radius_factor},
                             {"points", shell.size()}};
  ip->description += " + " + std::to_string(shell.size()) + " far-shell points";
  ip->points.insert(ip->points.end(), shell.begin(), shell.end());
}

InitialPoints triangulated_or_random(const Scene& scene, const InitPointsOptions& o) {
  log_info(scene.points.empty() ? "the scene has no SfM points: triangulating them from the training views"
           : o.mode == "auto"     ? "few-shot split: triangulating points from its " +
                                    std::to_string(scene.train_indices.size()) +
                                    " training views (the scene's SfM points also saw the test views)"
                                  : std::string("triangulating points from the training views (--init-points triangulate)"));
  const TriangulationOptions t = for_training(scene, o);
  CachedTriangulation c = triangulate_cached(scene, t, cache_dir_of(o));
  const nlohmann::json entry = {{"cache", c.path}, {"cached", c.hit}, {"stats", c.stats},
                                {"min_track_length", t.min_track_length}};
  std::string why;
  if (!c.failure.empty()) {
    why = "triangulation failed: " + c.failure;
  } else if (c.points.size() < o.min_points) {
    why = "triangulation kept " + std::to_string(c.points.size()) + " points, fewer than " + std::to_string(o.min_points);
  }
  if (!why.empty()) {
    log_warn(why + "; starting from random points");
    InitialPoints r = random_because(why);
    r.record["triangulation"] = entry;
    return r;
  }
  InitialPoints ip;
  ip.points = to_sfm_points(c.points);
  ip.source = "triangulated";
  ip.description = std::to_string(ip.points.size()) + " points triangulated from the training views (" +
                   (c.hit ? "cached in " : "now cached in ") + c.path + ")";
  ip.record = {{"source", "triangulated"}, {"points", ip.points.size()}, {"triangulation", entry}};
  return ip;
}

InitialPoints choose_points(const Scene& scene, const InitPointsOptions& o) {
  check_init_points_mode(o.mode);
  const Source source = source_of(scene, o);
  if (source == Source::kRandom) return random_because("--init-points random");
  InitialPoints ip;
  if (source == Source::kFile) {
    ip.points = read_points_file(o.mode);
    if (ip.points.empty()) fail(o.mode, "no points in the file (--init-points)");
    ip.source = "file";
    ip.description = std::to_string(ip.points.size()) + " points from " + o.mode;
    ip.record = {{"source", "file"}, {"file", absolute(o.mode)}, {"points", ip.points.size()}};
  } else if (source == Source::kScenePoints) {
    ip.points = scene.points;
    ip.source = "file";
    ip.description = std::to_string(ip.points.size()) + " SfM points from " + scene.points_file;
    ip.record = {{"source", "file"}, {"file", scene.points_file.empty() ? "" : absolute(scene.points_file)},
                 {"points", ip.points.size()}};
  } else {
    ip = triangulated_or_random(scene, o);
    if (ip.points.empty()) return ip;
  }
  add_shell(scene, o, &ip);
  return ip;
}

}  // namespace

void check_init_points_mode(const std::string& mode) {
  if (is_keyword(mode)) return;
  std::string ext = fs::path(mode).extension().string();
  if (ext != ".bin" && ext != ".txt") {
    fail_usage("--init-points must be auto, random, triangulate or a COLMAP points3D .bin/.txt file, got '" + mode + "'");
  }
  if (!fs::is_regular_file(mode)) fail(mode, "point file not found (--init-points)");
}

std::optional<int> few_shot_track_rule(const std::string& mode, int few_shot_views) {
  if (few_shot_views <= 0) return std::nullopt;
  // Whether the scene has its own points only matters to the full split (K = 0), which returned above.
  if (source_of(mode, few_shot_views, /*scene_has_points=*/true) != Source::kTriangulation) return std::nullopt;
  TriangulationOptions training;
  training.training_views_only = true;
  return few_shot_triangulation(few_shot_views, training).min_track_length;
}

InitialPoints choose_initial_points(const Scene& scene, const InitPointsOptions& o) {
  InitialPoints ip = choose_points(scene, o);
  ip.record["mode"] = o.mode;  // what was asked for: a resumed run asks for it again
  return ip;
}

InitialPoints describe_initial_points(const Scene& scene, const InitPointsOptions& o) {
  check_init_points_mode(o.mode);
  const Source source = source_of(scene, o);
  if (source == Source::kRandom) return random_because("--init-points random");
  InitialPoints ip;
  if (source == Source::kFile) {
    ip.source = "file";
    ip.description = "file " + o.mode;
  } else if (source == Source::kScenePoints) {
    ip.source = "file";
    ip.description = "file " + scene.points_file + " (" + std::to_string(scene.points.size()) + " points)";
  } else {
    CachedTriangulation c = find_cached_triangulation(scene, for_training(scene, o), cache_dir_of(o));
    if (!c.hit) {
      ip.source = "triangulated";
      ip.description = "triangulated from the training views when a field is first trained at this resolution "
                       "(not cached yet: " + c.path + ")";
    } else if (!c.failure.empty() || c.points.size() < o.min_points) {
      ip = random_because(c.failure.empty() ? std::to_string(c.points.size()) + " triangulated points, too few"
                                            : "triangulation failed: " + c.failure);
      ip.description += ", cached in " + c.path;
    } else {
      ip.source = "triangulated";
      ip.description = "triangulated, cached in " + c.path + " (" + std::to_string(c.points.size()) + " points)";
    }
  }
  ip.record["mode"] = o.mode;
  return ip;
}

}  // namespace lrf
