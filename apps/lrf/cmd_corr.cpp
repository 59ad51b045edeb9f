// lrf corr: pixel correspondences between the views of a scene, for Stage I.
#include <cstdio>
#include <filesystem>
#include <memory>

#include <nlohmann/json.hpp>

#include "command.h"
#include "lrf/align/correspondences.h"
#include "lrf/align/correspondences_database.h"
#include "lrf/align/correspondences_matching.h"
#include "lrf/align/correspondences_io.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "scene_options.h"

namespace {

struct CorrOptions {
  std::string scene, output, source = "auto", database;
  lrf::SceneOptions scene_options;
  lrf::MatchOptions match;
  bool json = false;
};

int run_corr(const CorrOptions& o) {
  lrf::Scene scene = lrf::load_scene(o.scene, o.scene_options);
  std::string source = o.source;
  std::string db = o.database.empty() ? (std::filesystem::path(o.scene) / "database.db").string() : o.database;
  if (source == "auto") source = scene.has_tracks ? "tracks" : std::filesystem::exists(db) ? "colmap-db" : "match";
  lrf::CorrespondenceSet set;
  if (source == "tracks") {
    set = lrf::correspondences_from_tracks(scene, o.match.min_inliers, o.match.training_views_only);
  } else if (source == "colmap-db") {
    set = lrf::correspondences_from_database(scene, db, o.match.min_inliers, o.match.training_views_only);
  } else {
    set = lrf::correspondences_from_matching(scene, o.match);
  }
  lrf::write_correspondences(o.output, set);
  lrf::CorrespondenceSummary s = lrf::summarize(set, scene);
  nlohmann::json j = {{"source", source},
                      {"pairs", s.pairs},
                      {"matches", s.matches},
                      {"matches_per_pair_mean", s.matches_per_pair_mean},
                      {"matches_per_pair_median", s.matches_per_pair_median},
                      {"epipolar_median_px", s.epipolar_median_px},
                      {"epipolar_mean_px", s.epipolar_mean_px},
                      {"width", scene.views[0].camera.width},
                      {"height", scene.views[0].camera.height}};
  if (o.json) {
    std::printf("%s\n", j.dump().c_str());
  } else {
    std::printf("source %s: %zu pairs, %zu matches (%.1f per pair, median %.0f), epipolar distance under the known "
                "poses: median %.3f px, mean %.3f px at %dx%d\nwrote %s\n",
                source.c_str(), s.pairs, s.matches, s.matches_per_pair_mean, s.matches_per_pair_median,
                s.epipolar_median_px, s.epipolar_mean_px, scene.views[0].camera.width, scene.views[0].camera.height,
                o.output.c_str());
  }
  return 0;
}

lrf::cli::CommandRegistration reg(30, [](CLI::App& root) {
  auto* corr = root.add_subcommand("corr", "Pixel correspondences between the views of a scene (for Stage I), with "
                                           "their epipolar error under the known poses");
  auto o = std::make_shared<CorrOptions>();
  corr->add_option("scene", o->scene, "Scene folder")->required();
  corr->add_option("-o,--output", o->output, "Correspondence file to write")->required();
  corr->add_option("--source", o->source,
                   "tracks: COLMAP tracks (images.bin); colmap-db: a COLMAP database.db; match: lrf's SIFT matcher; "
                   "auto: tracks, else database.db in the scene, else match")
      ->check(CLI::IsMember({"auto", "tracks", "colmap-db", "match"}))
      ->capture_default_str();
  corr->add_option("--database", o->database, "COLMAP database for --source colmap-db (default SCENE/database.db)");
  corr->add_option("--min-inliers", o->match.min_inliers, "Keep pairs with at least this many matches")->capture_default_str();
  corr->add_option("--min-inlier-ratio", o->match.min_inlier_ratio, "match: keep pairs whose RANSAC inlier ratio is at least this")
      ->capture_default_str();
  corr->add_option("--overlap", o->match.sequential_overlap, "match: pair each view with the next N views")->capture_default_str();
  corr->add_option("--quadratic-overlap", o->match.quadratic_overlap, "match: also pair view i with i + 2^k (1 = on)")
      ->capture_default_str();
  corr->add_option("--ratio", o->match.ratio_test, "match: Lowe's ratio test threshold")->capture_default_str();
  corr->add_option("--ransac-px", o->match.ransac_threshold_px, "match: RANSAC threshold on the fundamental matrix, pixels")
      ->capture_default_str();
  corr->add_option("--max-features", o->match.max_features, "match: SIFT features per image")->capture_default_str();
  corr->add_flag("--train-only", o->match.training_views_only, "Use only the training views (test views stay unseen)");
  corr->add_flag("--json", o->json, "Print the summary as one JSON object");
  lrf::cli::add_scene_options(corr, &o->scene_options);
  lrf::cli::on_run(corr, [o] { return run_corr(*o); });
});

}  // namespace
