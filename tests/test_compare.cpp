// lrf compare on a tiny synthetic scene: the table is written, finished methods are reused, and a method
// whose run was interrupted is finished from its checkpoint before it is scored, never scored as it was.
#include <filesystem>

#include <gtest/gtest.h>

#include "lrf/compare/compare.h"
#include "lrf/compare/compare_plan.h"
#include "lrf/core/atomic_file.h"
#include "lrf/core/cache_key.h"
#include "lrf/core/run_info.h"
#include "lrf/splat/run/train_run.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

namespace {

lrf::CompareOptions tiny_compare(const std::string& out) {
  lrf::CompareOptions o;
  o.scene = lrf::test::synthetic_scene();
  o.out = out;
  o.autoencoder = lrf::test::shared_dir() + "/models/taef2";
  o.cache_dir = "";
  o.iters = 40;
  o.methods = {"rgb/8", "latent"};
  return o;
}

// What an interruption leaves: a checkpoint and the point_cloud.ply it refreshed, but no "result" in
// config.json. The metrics.json beside it is made recognisable, as if scored from that unfinished field.
void make_unfinished(const fs::path& dir) {
  const std::string config_path = (dir / "config.json").string(), metrics_path = (dir / "metrics.json").string();
  nlohmann::json config = lrf::read_json_file(config_path);
  config.erase("result");
  lrf::write_json_file(config_path, config);
  nlohmann::json metrics = lrf::read_json_file(metrics_path);
  metrics["psnr"] = -1.0;
  lrf::write_json_file(metrics_path, metrics);
}

TEST(Compare, ReusesFinishedMethodsAndFinishesInterruptedOnesBeforeScoring) {
  lrf::test::TempDir dir("compare");
  lrf::CompareOptions o = tiny_compare(dir / "cmp");
  lrf::run_compare(o);
  for (const char* f : {"table.csv", "table.md", "report.html", "rgb_8/metrics.json", "latent/metrics.json"}) {
    EXPECT_TRUE(fs::exists(dir / ("cmp/" + std::string(f)))) << f;
  }
  ASSERT_TRUE(lrf::splat::run_finished(dir / "cmp/rgb_8"));
  ASSERT_TRUE(lrf::splat::run_finished(dir / "cmp/latent"));

  // A second call reuses both: no field is rewritten.
  const auto rgb_time = fs::last_write_time(dir / "cmp/rgb_8/point_cloud.ply");
  const auto latent_time = fs::last_write_time(dir / "cmp/latent/point_cloud.ply");
  lrf::run_compare(o);
  EXPECT_EQ(fs::last_write_time(dir / "cmp/rgb_8/point_cloud.ply"), rgb_time);
  EXPECT_EQ(fs::last_write_time(dir / "cmp/latent/point_cloud.ply"), latent_time);

  // Both runs interrupted (after their last checkpoint): the next call finishes them and scores again.
  make_unfinished(dir / "cmp/rgb_8");
  make_unfinished(dir / "cmp/latent");
  ASSERT_FALSE(lrf::splat::run_finished(dir / "cmp/rgb_8"));
  lrf::run_compare(o);
  const fs::path cmp = dir / "cmp";
  for (const char* m : {"rgb_8", "latent"}) {
    SCOPED_TRACE(m);
    EXPECT_TRUE(lrf::splat::run_finished((cmp / m).string()));
    EXPECT_GT(lrf::read_json_file((cmp / m / "metrics.json").string()).value("psnr", -1.0), 0.0);
  }
  const std::string table = lrf::read_file(dir / "cmp/table.csv");
  EXPECT_EQ(table.find("-1"), std::string::npos) << table;
  EXPECT_EQ(table.rfind("method,psnr,ssim,ms_ssim,flip,lpips,", 0), 0u) << table;
  // The efficiency table: what each method is fitted to (64x48 views; the latent is 8x6 with TAEF2's 32
  // channels), with its time, memory and speed from the same metrics.
  const std::string efficiency = lrf::read_file(dir / "cmp/efficiency.csv");
  EXPECT_EQ(efficiency.rfind("method,fitted_to,train_seconds,peak_memory_mb,storage_mb,gaussians,render_fps,decode_fps,"
                             "psnr,ssim,view_fps\n", 0), 0u) << efficiency;
  EXPECT_NE(efficiency.find("\nrgb/8,8x6 RGB,"), std::string::npos) << efficiency;
  EXPECT_NE(efficiency.find("\nlatent,8x6x32 latents,"), std::string::npos) << efficiency;
  // The tables a person reads ask one question each: quality in table.md, cost in efficiency.md, with
  // labels and units; a latent row's view rate includes its decode.
  const std::string quality_md = lrf::read_file(dir / "cmp/table.md"), cost_md = lrf::read_file(dir / "cmp/efficiency.md");
  EXPECT_NE(quality_md.find("PSNR dB"), std::string::npos) << quality_md;
  EXPECT_EQ(quality_md.find("fit time"), std::string::npos) << quality_md;
  EXPECT_NE(cost_md.find("view fps"), std::string::npos) << cost_md;
  EXPECT_EQ(cost_md.find("PSNR"), std::string::npos) << cost_md;
  const nlohmann::json latent_metrics = lrf::read_json_file(dir / "cmp/latent/metrics.json");
  const double render = latent_metrics["render_fps"], decode = latent_metrics["decode_fps"];
  const std::string last_line = efficiency.substr(efficiency.rfind("\nlatent,") + 1);
  const double view = std::stod(last_line.substr(last_line.rfind(',') + 1));
  EXPECT_NEAR(view, 1.0 / (1.0 / render + 1.0 / decode), 1e-3 * view) << efficiency;
  EXPECT_LT(view, render);
  EXPECT_NE(lrf::read_file(dir / "cmp/report.html").find("<h2>Efficiency</h2>"), std::string::npos);
  const double flip = lrf::read_json_file((cmp / "latent" / "metrics.json").string()).value("flip", -1.0);
  EXPECT_GT(flip, 0.0);
  EXPECT_LT(flip, 1.0);
}

// The report describes the methods of its table and no others, labels its columns and marks which way is better,
// and names lrf once in its footer (it read "lrf lrf 0.1.0").
TEST(Compare, ReportDescribesOnlyItsMethods) {
  lrf::test::TempDir dir("compare_report");
  lrf::CompareOptions o = tiny_compare(dir / "cmp");
  o.methods = {"rgb/8"};
  lrf::run_compare(o);
  const std::string html = lrf::read_file(dir / "cmp/report.html");
  const size_t notes = html.find("<h2>Notes</h2>");
  ASSERT_NE(notes, std::string::npos);
  const std::string text = html.substr(notes, html.find("</div>", notes) - notes);
  EXPECT_NE(text.find("rgb/8: RGB 3D Gaussian splatting trained on the views downscaled 8x"), std::string::npos) << text;
  for (const char* other : {"rgb/8-mip:", "rgb-mip:", "rgb:", "latent:", "latent-refined:", "latent-nerf:", "feature-gs:",
                            "3DGS-VAE", "Feature 3DGS"}) {
    EXPECT_EQ(text.find(other), std::string::npos) << other << " in " << text;
  }
  EXPECT_NE(html.find("FLIP <span title=\"lower is better\">&darr;</span>"), std::string::npos);
  EXPECT_NE(html.find("PSNR dB <span title=\"higher is better\">&uarr;</span>"), std::string::npos);
  EXPECT_NE(html.find("<footer>Written by lrf 0."), std::string::npos);
  EXPECT_EQ(html.find("lrf lrf"), std::string::npos);
}

// Few-shot: every method trains on the same K views (recorded), never starts from the scene's own SfM
// points (reconstructed from every view, test views included), and the folder refuses other settings.
TEST(Compare, FewShotTrainsEveryMethodOnTheSameViewsAndRefusesOtherSettings) {
  lrf::test::TempDir dir("compare_few_shot");
  lrf::CompareOptions o = tiny_compare(dir / "cmp");
  o.scene_options.train_views = 3;  // test view 0; training views 1..7 at positions 0, 3, 6
  o.methods = {"rgb-mip", "latent"};  // Table 2's Mip-Splatting row: full resolution, with the filters
  lrf::run_compare(o);
  EXPECT_EQ(lrf::read_json_file(dir / "cmp/rgb-mip/config.json")["mip"], true);
  EXPECT_NE(lrf::read_file(dir / "cmp/efficiency.csv").find("\nrgb-mip,64x48 RGB,"), std::string::npos);
  const nlohmann::json names = {"view_001.png", "view_004.png", "view_007.png"};
  for (const char* m : {"rgb-mip", "latent"}) {
    SCOPED_TRACE(m);
    const nlohmann::json config = lrf::read_json_file(dir / (std::string("cmp/") + m + "/config.json"));
    EXPECT_EQ(config["train_views"], 3);
    EXPECT_EQ(config["few_shot_views"], 3);
    EXPECT_EQ(config["few_shot_view_names"], names);
    EXPECT_NE(config["init_points"].value("source", std::string()), "file") << config["init_points"].dump();
    // Triangulated from the K views with two-view tracks: K views far apart share few three-view tracks.
    EXPECT_EQ(config["init_points"]["triangulation"].value("min_track_length", 0), 2) << config["init_points"].dump();
    EXPECT_EQ(lrf::read_json_file(dir / (std::string("cmp/") + m + "/metrics.json"))["views"].size(), 1u);
  }
  EXPECT_EQ(lrf::read_json_file(dir / "cmp/compare.json")["training_views"], names);
  lrf::CompareOptions all_views = o;
  all_views.scene_options.train_views = 0;
  const std::string msg = lrf::test::error_of([&] { lrf::run_compare(all_views); });
  EXPECT_NE(msg.find("this folder holds methods made with other settings"), std::string::npos) << msg;
  EXPECT_NE(msg.find("train_views (3 vs 0)"), std::string::npos) << msg;
  // The latent field's SH degree is checked on the field itself (the RGB rows do not depend on it).
  lrf::CompareOptions sh0 = o;
  sh0.latent_sh_degree = 0;
  const std::string sh_msg = lrf::test::error_of([&] { lrf::run_compare(sh0); });
  EXPECT_NE(sh_msg.find("this field has SH degree 1, this run asks for --latent-sh-degree 0"), std::string::npos)
      << sh_msg;
  // A folder from before the images were undistorted with the Lanczos kernel holds fields fitted to other images.
  nlohmann::json summary = lrf::read_json_file(dir / "cmp/compare.json");
  const nlohmann::json view_images = summary["settings"]["view_images"];
  summary["settings"].erase("view_images");
  lrf::write_json_file(dir / "cmp/compare.json", summary);
  const std::string old_msg = lrf::test::error_of([&] { lrf::run_compare(o); });
  EXPECT_NE(old_msg.find("view_images (none vs 2)"), std::string::npos) << old_msg;
  // So does a few-shot folder from before K-view splits triangulated with two-view tracks (its fields
  // could have started from random points).
  summary = lrf::read_json_file(dir / "cmp/compare.json");
  ASSERT_EQ(summary["settings"]["initial_points_min_track_length"], 2);
  summary["settings"]["view_images"] = view_images;  // as written by this build: only the rule is missing
  summary["settings"].erase("initial_points_min_track_length");
  lrf::write_json_file(dir / "cmp/compare.json", summary);
  const std::string rule_msg = lrf::test::error_of([&] { lrf::run_compare(o); });
  EXPECT_NE(rule_msg.find("initial_points_min_track_length (none vs 2)"), std::string::npos) << rule_msg;
}

// The latent-refined row is reused only when its refinement was made with the refine options asked for
// now: more steps continue one at constant rates, other options are refused (a changed default must not pass for the old).
TEST(Compare, RefinedRowIsReusedOnlyWithTheSameRefineOptions) {
  lrf::test::TempDir dir("compare_refined");
  lrf::CompareOptions o = tiny_compare(dir / "cmp");
  o.methods = {"latent-refined"};
  o.refine.steps = 3;
  o.refine.score_every = 2;
  o.refine.lr_final = 1;  // constant rates, so that more steps continue the run
  lrf::run_compare(o);
  const fs::path refined = dir / "cmp/latent-refined";
  ASSERT_TRUE(lrf::splat::run_finished(refined.string()));
  // The row's time is the whole row's: encode, fit and refinement, each also on its own.
  const auto metrics = lrf::read_json_file((refined / "metrics.json").string());
  EXPECT_NEAR(metrics["train_seconds"].get<double>(),
              metrics["encode_seconds"].get<double>() + metrics["fit_seconds"].get<double>() +
                  metrics["refine_seconds"].get<double>(),
              1e-6);
  EXPECT_GT(metrics["refine_seconds"].get<double>(), 0);
  // Its quality curve (steps 2 and 3) is drawn in the report, beside another run's given with --curve.
  EXPECT_EQ(lrf::test::logged_column((refined / "curve.csv").string(), "step"), (std::vector<double>{2, 3}));
  const std::string report = lrf::read_file(dir / "cmp/report.html");
  EXPECT_NE(report.find("<svg class=\"chart\""), std::string::npos);
  EXPECT_NE(report.find("latent-refined (this run)"), std::string::npos);
  lrf::CompareOptions with_curve = o;
  with_curve.curves = {"the other run=" + (refined / "curve.csv").string()};
  lrf::run_compare(with_curve);
  EXPECT_NE(lrf::read_file(dir / "cmp/report.html").find("the other run"), std::string::npos);
  with_curve.curves = {"no-equals-sign"};
  EXPECT_NE(lrf::test::error_of([&] { lrf::run_compare(with_curve); }).find("NAME=CSV"), std::string::npos);
  const auto refined_time = fs::last_write_time(refined / "point_cloud.ply");
  lrf::run_compare(o);  // same options: reused
  EXPECT_EQ(fs::last_write_time(refined / "point_cloud.ply"), refined_time);

  o.refine.steps = 4;  // constant rates: continued, and scored again
  lrf::run_compare(o);
  EXPECT_EQ(lrf::read_json_file((refined / "config.json").string())["result"]["steps"], 4);
  EXPECT_EQ(lrf::read_json_file((refined / "metrics.json").string())["field_stamp"],
            lrf::file_stamp((refined / "point_cloud.ply").string()));

  lrf::CompareOptions other = o;
  other.refine.jitter = 0;
  std::string msg = lrf::test::error_of([&] { lrf::run_compare(other); });
  EXPECT_NE(msg.find("the latent-refined field in this folder was made with other settings"), std::string::npos) << msg;
  EXPECT_NE(msg.find("jitter"), std::string::npos) << msg;
  other = o;
  other.refine.steps = 2;
  msg = lrf::test::error_of([&] { lrf::run_compare(other); });
  EXPECT_NE(msg.find("steps (4 vs 2)"), std::string::npos) << msg;
  // The default schedule (a decay at the end) is another run, not a continuation of the constant one.
  other = o;
  other.refine.lr_final = lrf::RefineOptions().lr_final;
  other.refine.lr_decay_start = lrf::RefineOptions().lr_decay_start;
  msg = lrf::test::error_of([&] { lrf::run_compare(other); });
  EXPECT_NE(msg.find("\"lr_final\":0.1"), std::string::npos) << msg;
}

// The plan printed before each method names the refinement's length as the run will resolve it.
// An unknown method is a usage error (exit 2) that names the known ones, and nothing is written.
TEST(Compare, UnknownMethodIsAUsageErrorBeforeAnyWork) {
  lrf::test::TempDir tmp("compare_unknown");
  auto r = lrf::test::run_lrf("compare '" + lrf::test::synthetic_scene() + "' --methods rgb/8 rgb-nope -o '" +
                              (tmp / "out") + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--methods: unknown method 'rgb-nope' (rgb, "), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(tmp / "out"));
}

TEST(Compare, PlanNamesTheRefinementLength) {
  lrf::CompareOptions o;
  EXPECT_NE(lrf::compare_method_plan("latent-refined", o).find(std::to_string(lrf::kRefineStepsPerView) +
                                                               " steps per training view"),
            std::string::npos);
  o.refine.steps = 300;
  EXPECT_NE(lrf::compare_method_plan("latent-refined", o).find("for 300 steps"), std::string::npos);
}

}  // namespace
