// lrf scene points: triangulate a scene's points from its known poses (lrf's SIFT matcher or a COLMAP
// database.db, or COLMAP's point_triangulator), and write them as COLMAP points3D or .ply.
#include <cstdio>
#include <memory>

#include <nlohmann/json.hpp>

#include "command.h"
#include "lrf/core/cache_key.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/points/cloud_distance.h"
#include "lrf/points/colmap_triangulation.h"
#include "lrf/points/points_cache.h"
#include "lrf/points/points_file.h"
#include "lrf/points/scene_triangulation.h"
#include "lrf/scene/colmap_model.h"
#include "lrf/scene/scene.h"
#include "lrf/scene/scene_outputs.h"
#include "scene_options.h"

namespace {

struct PointsOptions {
  std::string scene;
  lrf::SceneOptions scene_options;
  std::vector<std::string> outputs;
  std::string with = "lrf";
  std::string views = "all";
  std::string reference;
  std::string cache_dir;
  std::string colmap_work;
  bool json = false;
  lrf::TriangulationOptions t;
  bool min_track_given = false;  // --min-track-length was passed (else a few-shot split keeps two-view tracks)
};

nlohmann::json summary(const PointsOptions& o, const lrf::TriangulatedPoints& r, const std::string& cache_path) {
  nlohmann::json j = r.stats.to_json();
  j["with"] = o.with;
  j["matches_from"] = r.matches_from;
  j["views_used"] = o.views;
  if (!cache_path.empty()) j["cache"] = cache_path;
  if (!o.outputs.empty()) j["outputs"] = o.outputs;
  return j;
}

int run_points(PointsOptions o) {
  using namespace lrf;
  if (o.views != "all" && o.views != "train") fail_usage("--views must be all or train");
  o.t.training_views_only = o.views == "train";
  Scene scene = load_scene(o.scene, o.scene_options);
  for (const auto& path : o.outputs) refuse_output_over_scene_files(path, scene);
  if (!o.min_track_given) o.t = few_shot_triangulation(scene.few_shot_views, o.t);  // as training triangulates the split
  TriangulatedPoints result;
  std::string cache_path;
  if (o.with == "colmap") {
    ColmapTriangulationOptions c;
    c.work_dir = o.colmap_work;
    result = triangulate_with_colmap(scene, o.t, c);
  } else if (o.outputs.empty() || !o.cache_dir.empty()) {
    // Through the cache that training reads: `--views train` at a training resolution prepares it.
    CachedTriangulation c = triangulate_cached(scene, o.t, o.cache_dir.empty() ? default_cache_dir() : o.cache_dir);
    if (!c.failure.empty()) throw Error(c.failure);
    result.points = std::move(c.points);
    result.matches_from = o.t.database.empty() ? "sift" : o.t.database;
    cache_path = c.path;
    if (c.hit) log_info("read from the cache: " + c.path + " (its statistics are those of the run that made it)");
    result.stats.points = result.points.size();
    const auto& s = c.stats;
    result.stats.views = s.value("views", size_t{0});
    result.stats.pairs = s.value("pairs", size_t{0});
    result.stats.matches = s.value("matches", size_t{0});
    result.stats.tracks = s.value("tracks", size_t{0});
    result.stats.too_short = s.value("rejected_too_short", size_t{0});
    result.stats.inconsistent = s.value("rejected_inconsistent", size_t{0});
    result.stats.mean_error_px = s.value("mean_error_px", 0.0);
    result.stats.median_error_px = s.value("median_error_px", 0.0);
    result.stats.mean_track_length = s.value("mean_track_length", 0.0);
    result.stats.median_angle_deg = s.value("median_angle_deg", 0.0);
  } else {
    result = triangulate_scene(scene, o.t);
  }
  for (const auto& path : o.outputs) write_points_file(path, result.points);

  nlohmann::json j = summary(o, result, cache_path);
  if (!o.reference.empty()) {
    std::vector<Eigen::Vector3d> mine, theirs;
    for (const auto& p : result.points) mine.push_back(p.xyz);
    for (const auto& p : read_colmap_points(o.reference)) theirs.push_back(p.xyz);
    if (theirs.empty()) fail(o.reference, "no points in the reference file");
    j["reference"] = cloud_distance(mine, theirs).to_json();
    j["reference"]["file"] = o.reference;
    j["reference"]["points"] = theirs.size();
  }
  if (o.json) {
    std::printf("%s\n", j.dump().c_str());
    return 0;
  }
  const auto& s = result.stats;
  std::printf("scene        %s (%zu views used, matches from %s)\n", o.scene.c_str(), s.views, result.matches_from.c_str());
  if (o.with == "lrf") {
    std::printf("matches      %zu in %zu view pairs -> %zu tracks (%zu seen in too few views, %zu inconsistent)\n",
                s.matches, s.pairs, s.tracks, s.too_short, s.inconsistent);
  }
  std::printf("points       %zu\nreprojection mean %.3f px, median %.3f px\ntrack length mean %.2f views\n", s.points,
              s.mean_error_px, s.median_error_px, s.mean_track_length);
  if (o.with == "lrf") std::printf("angle        median %.2f degrees\n", s.median_angle_deg);
  if (j.contains("reference")) {
    const auto& r = j["reference"];
    std::printf("reference    %s (%zu points, median distance from their median %.4g, median spacing %.4g)\n",
                o.reference.c_str(), r["points"].get<size_t>(), r["reference_spread"].get<double>(),
                r["reference_spacing"].get<double>());
    std::printf("distance     median %.4g, mean %.4g to the nearest reference point; median %.4g from each "
                "reference point to ours\n",
                r["median_to_reference"].get<double>(), r["mean_to_reference"].get<double>(),
                r["median_from_reference"].get<double>());
  }
  if (!cache_path.empty()) std::printf("cache        %s\n", cache_path.c_str());
  for (const auto& path : o.outputs) std::printf("wrote        %s\n", path.c_str());
  return 0;
}

lrf::cli::CommandRegistration reg(11, [](CLI::App& root) {
  CLI::App* scene = root.get_subcommand("scene");
  auto* cmd = scene->add_subcommand(
      "points",
      "Triangulate a scene's points from its known poses (for scenes without SfM points: transforms.json, LLFF "
      "without points3D): SIFT matches between overlapping views (or a COLMAP database.db), tracks, multi-view "
      "triangulation, filtered by reprojection error, triangulation angle and track length, coloured from the "
      "images. Without -o the points go to the cache that lrf train reads (never into the scene folder)");
  auto o = std::make_shared<PointsOptions>();
  cmd->add_option("scene", o->scene, "Scene folder")->required();
  lrf::cli::add_scene_options(cmd, &o->scene_options);
  cmd->add_option("-o,--output", o->outputs,
                  "Write the points here; the format follows the extension: .bin / .txt (COLMAP points3D, with each "
                  "point's reprojection error) or .ply (x y z, colours). Repeat for several files");
  cmd->add_option("--with", o->with,
                  "Triangulator: lrf (its own) or colmap (COLMAP's point_triangulator on the same views, cameras and "
                  "view pairs; needs the colmap program, run on the CPU)")
      ->check(CLI::IsMember({"lrf", "colmap"}))
      ->capture_default_str();
  cmd->add_option("--views", o->views,
                  "Views to triangulate from: all, or train (the training views only, as lrf train does: with the "
                  "same scene options this fills the very cache entry training reads)")
      ->check(CLI::IsMember({"all", "train"}))
      ->capture_default_str();
  cmd->add_option("--database", o->t.database,
                  "Take the matches from this COLMAP database.db (its two-view geometries' inliers) instead of "
                  "lrf's SIFT matcher");
  cmd->add_option("--neighbours", o->t.neighbours,
                  "Match each view with this many nearest views (camera centres) that look the same way "
                  "(optical axes within 90 degrees)")
      ->capture_default_str();
  cmd->add_option("--max-features", o->t.match.max_features, "SIFT features per view")->capture_default_str();
  cmd->add_option("--ratio", o->t.match.ratio_test, "Lowe's ratio test (mutual nearest neighbours)")->capture_default_str();
  cmd->add_option("--ransac-px", o->t.match.ransac_threshold_px,
                  "RANSAC threshold on the fundamental matrix, pixels")->capture_default_str();
  cmd->add_option("--min-inliers", o->t.match.min_inliers, "View pairs need this many inlier matches")
      ->capture_default_str();
  cmd->add_option("--max-error", o->t.max_error_px,
                  "Keep a point's observation when it reprojects within this many pixels")->capture_default_str();
  cmd->add_option("--min-angle", o->t.min_angle_deg,
                  "Keep points whose rays meet at this many degrees at least (smaller: depth too uncertain)")
      ->capture_default_str();
  cmd->add_option_function<int>(
         "--min-track-length",
         [o](const int& n) {
           o->t.min_track_length = n;
           o->min_track_given = true;
         },
         "Keep points seen in at least this many views (default 3; 2 for a few-shot split's training views, "
         "as lrf train triangulates them)");
  cmd->add_option("--seed", o->t.seed, "Seed of the choice of seed pairs in long tracks")->capture_default_str();
  cmd->add_option("--reference", o->reference,
                  "Compare with this COLMAP points3D.bin/.txt (same poses, so the same frame): nearest-neighbour "
                  "distances both ways");
  cmd->add_option("--cache-dir", o->cache_dir,
                  "Points cache folder (default $LRF_CACHE or ~/.cache/lrf); with -o the cache is used only when "
                  "this is given");
  cmd->add_option("--colmap-work", o->colmap_work,
                  "--with colmap: keep COLMAP's work folder (images, database, models, log) here (default: a "
                  "temporary folder, removed after)");
  cmd->add_flag("--json", o->json,
                "Print one JSON object: views, pairs, matches, tracks, points, rejected_too_short, "
                "rejected_inconsistent, mean_error_px, median_error_px, mean_track_length, median_angle_deg, with, "
                "matches_from, and with --reference its distances");
  lrf::cli::on_run(cmd, [o] { return run_points(*o); });
});

}  // namespace
