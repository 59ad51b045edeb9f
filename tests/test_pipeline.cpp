// lrf pipeline on tiny synthetic scenes: every artefact and table is written, evaluation scenes feed no
// training stage (asserted from the stages' own records), and a re-run reuses everything.
#include <algorithm>
#include <filesystem>
#include <map>

#include <gtest/gtest.h>

#include "lrf/core/atomic_file.h"
#include "lrf/core/cache_key.h"
#include "lrf/core/error.h"
#include "lrf/core/run_info.h"
#include "lrf/pipeline/pipeline.h"
#include "lrf/pipeline/scene_mean.h"
#include "test_helpers.h"

namespace fs = std::filesystem;
using lrf::test::error_of;

namespace {

lrf::PipelineOptions tiny_pipeline(const std::string& out) {
  lrf::PipelineOptions o;
  o.train_scenes = {lrf::test::synthetic_scene()};
  o.eval_scenes = {lrf::test::synthetic_scene({8, "64x48", 11, 800})};
  o.autoencoder = lrf::test::shared_dir() + "/models/taef2";
  o.out = out;
  o.cache_dir = "";
  o.max_side = 0;
  o.stage1.steps = 3;
  o.stage1.batch.crop = 48;
  o.stage1.lr = 1e-4;
  o.field_iters = 60;
  o.stage3.steps = 3;
  o.refine.steps = 3;
  o.rgb_full = true;  // every row of the ablation
  return o;
}

std::vector<std::string> strings(const nlohmann::json& a) {
  std::vector<std::string> v;
  for (const auto& s : a) v.push_back(s.get<std::string>());
  return v;
}

TEST(Pipeline, RunsAllStagesWithoutLeakageAndReusesArtefacts) {
  lrf::test::TempDir dir("pipeline");
  lrf::PipelineOptions o = tiny_pipeline(dir / "run");
  o.refine.lr_final = 1;  // constant rates, so that the refinement can be continued below
  EXPECT_EQ(fs::path(lrf::run_pipeline(o)["table"].get<std::string>()), fs::path(dir / "run/ablation.md"));
  for (const char* f : {"ablation.csv", "ablation.md", "report.html", "pipeline.json", "stage1/encoder.safetensors",
                        "stage3/decoder-stock.safetensors", "stage3/decoder-ft.safetensors"}) {
    EXPECT_TRUE(fs::exists(dir / ("run/" + std::string(f)))) << f;
  }
  const std::string csv = lrf::read_file(dir / "run/ablation.csv");
  for (const auto& row : lrf::ablation_rows()) EXPECT_NE(csv.find("," + row + ","), std::string::npos) << row;
  EXPECT_EQ(csv.rfind("scene,method,psnr,delta_psnr,ssim,ms_ssim,flip,lpips,", 0), 0u) << csv;
  // The detail row borrowed only the evaluation scene's training photographs, chose its weight on training
  // views, and is scored on the both+refine field it records.
  {
    const std::string scene = fs::path(o.eval_scenes[0]).filename().string();
    const nlohmann::json detail = lrf::read_json_file(dir / ("run/eval/" + scene + "/both+refine+detail/metrics.json"));
    const nlohmann::json refined = lrf::read_json_file(dir / ("run/eval/" + scene + "/both+refine/metrics.json"));
    EXPECT_EQ(detail["field_stamp"], refined["field_stamp"]);
    std::vector<std::string> test_views;
    for (const auto& v : refined["views"]) test_views.push_back(v["name"]);
    EXPECT_FALSE(detail["borrowed_views"].empty());
    for (const auto& name : strings(detail["borrowed_views"]))
      EXPECT_EQ(std::count(test_views.begin(), test_views.end(), name), 0) << name;
    for (const auto& name : strings(detail["calibration"]["training_views"]))
      EXPECT_EQ(std::count(test_views.begin(), test_views.end(), name), 0) << name;
  }
  // With one evaluation scene, its rows are shown once: no "mean" block repeating them (the demo's table
  // used to), and the report has no mean table; pipeline.json's mean is still that scene's scores.
  {
    const std::string scene = fs::path(o.eval_scenes[0]).filename().string();
    for (const auto& row : lrf::ablation_rows()) EXPECT_NE(csv.find("\n" + scene + "," + row + ","), std::string::npos) << row;
    EXPECT_EQ(csv.find("\nmean,"), std::string::npos) << csv;
    const std::string html = lrf::read_file(dir / "run/report.html");
    EXPECT_EQ(html.find("Mean over 1 evaluation scene"), std::string::npos);
    EXPECT_NE(html.find("\u0394 PSNR dB"), std::string::npos);
    const std::string md = lrf::read_file(dir / "run/ablation.md");
    EXPECT_NE(md.find("| scene"), std::string::npos) << md;
    // Two decimals for PSNRs and their differences, three for SSIM-like scores: never five.
    EXPECT_EQ(md.find(".00000"), std::string::npos) << md;
    const nlohmann::json record = lrf::read_json_file(dir / "run/pipeline.json");
    EXPECT_TRUE(record["mean"]["scores"].contains("stock")) << record["mean"].dump();
  }

  // Wall time per stage, from each stage's own record: every stage took time, and the table's total is
  // the sum of its rows.
  const nlohmann::json stages = lrf::read_json_file(dir / "run/pipeline.json")["stage_seconds"];
  std::vector<std::string> names;
  double sum = 0;
  for (const auto& s : stages) {
    names.push_back(s["stage"]);
    EXPECT_GT(s["seconds"].get<double>(), 0.0) << s.dump();
    sum += s["seconds"].get<double>();
  }
  EXPECT_EQ(names, (std::vector<std::string>{"Stage I", "Stage II", "Stage III", "Stage II", "refinement", "baselines"}));
  const std::string stage_csv = lrf::read_file(dir / "run/stages.csv");
  EXPECT_EQ(stage_csv.rfind("stage,what,runs,seconds,minutes\n", 0), 0u) << stage_csv;
  EXPECT_NE(stage_csv.find("\ntotal,,13,"), std::string::npos) << stage_csv;  // 1 + 2 + 2 + 2 + 2 + 4 runs
  const size_t total_at = stage_csv.find("\ntotal,,13,") + 11;
  EXPECT_NEAR(std::stod(stage_csv.substr(total_at)), sum, 1e-3 * sum + 1e-6) << stage_csv;
  EXPECT_TRUE(fs::exists(dir / "run/stages.md"));
  EXPECT_NE(lrf::read_file(dir / "run/report.html").find("Wall time per stage"), std::string::npos);

  // No leakage: what Stage I and both Stage III runs were trained on, from their own records, never
  // includes an evaluation scene, and is exactly the training scenes.
  nlohmann::json rec = lrf::read_json_file(dir / "run/pipeline.json");
  const auto eval = strings(rec["options"]["eval_scenes"]);
  const auto train = strings(rec["options"]["train_scenes"]);
  const auto stage1 = strings(lrf::read_json_file(dir / "run/stage1/encoder.json")["options"]["scenes"]);
  ASSERT_EQ(stage1.size(), 1u);
  EXPECT_EQ(fs::weakly_canonical(stage1[0]), fs::weakly_canonical(train[0]));
  for (const char* stage : {"stage1", "stage3_stock", "stage3_ft"}) {
    const auto used = strings(rec["trained_on"][stage]);
    EXPECT_FALSE(used.empty()) << stage;
    for (const auto& u : used) {
      for (const auto& e : eval) EXPECT_NE(fs::weakly_canonical(u), fs::weakly_canonical(e)) << stage;
    }
  }

  // A second run reuses every artefact: nothing is retrained (the files keep their times).
  const auto enc_time = fs::last_write_time(dir / "run/stage1/encoder.safetensors");
  const auto dec_time = fs::last_write_time(dir / "run/stage3/decoder-ft.safetensors");
  const std::string refined = dir / "run/fields/" + fs::path(o.eval_scenes[0]).filename().string() + "-ft-refined";
  const auto refined_time = fs::last_write_time(refined + "/point_cloud.ply");
  // The both+refine field was refined through the Stage III decoder, which adapted to the scene with it
  // (the default), and its row is decoded by that adapted decoder.
  const nlohmann::json refined_config = lrf::read_json_file(refined + "/config.json");
  EXPECT_EQ(refined_config["refine_source_decoder"], dir / "run/stage3/decoder-ft.safetensors");
  EXPECT_EQ(refined_config["decoder"], fs::absolute(refined + "/decoder.safetensors").lexically_normal().string());
  // A row scored by an older lrf (no FLIP) is scored again, without retraining anything.
  const std::string stock_scores = dir / "run/eval/" + fs::path(o.eval_scenes[0]).filename().string() + "/stock/metrics.json";
  nlohmann::json old_scores = lrf::read_json_file(stock_scores);
  ASSERT_TRUE(old_scores.contains("flip"));
  old_scores.erase("flip");
  lrf::write_json_file(stock_scores, old_scores);
  lrf::run_pipeline(o);
  EXPECT_TRUE(lrf::read_json_file(stock_scores).contains("flip"));
  EXPECT_EQ(fs::last_write_time(dir / "run/stage1/encoder.safetensors"), enc_time);
  EXPECT_EQ(fs::last_write_time(dir / "run/stage3/decoder-ft.safetensors"), dec_time);
  EXPECT_EQ(fs::last_write_time(refined + "/point_cloud.ply"), refined_time);

  // The same folder with other Stage I options is refused, not mixed.
  lrf::PipelineOptions other = o;
  other.stage1.lambda_corres = 3.0;
  std::string msg = error_of([&] { lrf::run_pipeline(other); });
  EXPECT_NE(msg.find("Stage I encoder in this folder was made with other settings"), std::string::npos) << msg;
  EXPECT_NE(msg.find("lambda_corres"), std::string::npos) << msg;
  // So are fields of another length (the rgb/8 baseline and latent fields alike).
  other = o;
  other.field_iters = o.field_iters + 1;
  msg = error_of([&] { lrf::run_pipeline(other); });
  EXPECT_NE(msg.find("the field in this folder was made with other settings"), std::string::npos) << msg;
  EXPECT_NE(msg.find("iters (60 vs 61)"), std::string::npos) << msg;
  // A few-shot protocol in the same folder gets its own evaluation fields and tables beside the full ones,
  // from the same Stage I and Stage III (reused, not refitted), and leaves the full protocol's table as it was.
  const std::string scene = fs::path(o.eval_scenes[0]).filename().string();
  const std::string full_table = lrf::read_file(dir / "run/ablation.csv");
  other = o;
  other.eval_train_views = 3;
  other.rgb_full = false;
  const nlohmann::json few_shot_record = lrf::run_pipeline(other);
  // What `lrf pipeline` prints: this protocol's table, not the full one beside it.
  EXPECT_EQ(fs::path(few_shot_record["table"].get<std::string>()), fs::path(dir / "run/ablation-3views.md"));
  EXPECT_EQ(fs::last_write_time(dir / "run/stage1/encoder.safetensors"), enc_time);
  EXPECT_EQ(fs::last_write_time(dir / "run/stage3/decoder-ft.safetensors"), dec_time);
  EXPECT_EQ(lrf::read_file(dir / "run/ablation.csv"), full_table);
  EXPECT_EQ(lrf::read_json_file(dir / "run/pipeline.json")["options"]["eval_train_views"], 0);
  EXPECT_EQ(lrf::read_json_file(dir / "run/pipeline-3views.json")["options"]["eval_train_views"], 3);
  for (const char* tag : {"stock", "ft", "ft-refined", "rgb8mip"}) {
    const nlohmann::json config = lrf::read_json_file(dir / "run/fields/" + scene + "-3views-" + tag + "/config.json");
    EXPECT_EQ(config.value("few_shot_views", 0), 3) << tag;
  }
  const std::string few_shot_table = lrf::read_file(dir / "run/ablation-3views.csv");
  for (const char* row : {"stock", "both", "both+refine", "rgb/8-mip"}) {
    EXPECT_NE(few_shot_table.find(scene + "-3views," + row + ","), std::string::npos) << row << "\n" << few_shot_table;
  }
  for (const char* f : {"ablation-3views.md", "stages-3views.csv", "stages-3views.md", "report-3views.html"}) {
    EXPECT_TRUE(fs::exists(dir / ("run/" + std::string(f)))) << f;
  }
  // A K-view field records the track rule of its start; one made before the rule was recorded (a 3-view
  // field then started from random points) is refused rather than reused in the table.
  const fs::path stock_config = dir / ("run/fields/" + scene + "-3views-stock/config.json");
  const nlohmann::json current = lrf::read_json_file(stock_config.string());
  EXPECT_EQ(current["init_points"]["triangulation"]["min_track_length"], 2);
  nlohmann::json earlier = current;
  earlier["init_points"]["triangulation"].erase("min_track_length");
  lrf::write_json_file(stock_config.string(), earlier);
  msg = error_of([&] { lrf::run_pipeline(other); });
  EXPECT_NE(msg.find("initial_points_min_track_length (none vs 2)"), std::string::npos) << msg;
  lrf::write_json_file(stock_config.string(), current);
  // A refinement with constant rates is continued to a larger step count, and its rows are
  // scored again; the other artefacts stay as they were.
  other = o;
  other.refine.steps = 5;
  lrf::run_pipeline(other);
  EXPECT_EQ(lrf::read_json_file(refined + "/config.json")["result"]["steps"], 5);
  const std::string refined_scores = dir / "run/eval/" + fs::path(o.eval_scenes[0]).filename().string() + "/both+refine/metrics.json";
  EXPECT_EQ(lrf::read_json_file(refined_scores)["field_stamp"], lrf::file_stamp(refined + "/point_cloud.ply"));
  const std::string detail_scores = dir / "run/eval/" + fs::path(o.eval_scenes[0]).filename().string() + "/both+refine+detail/metrics.json";
  EXPECT_EQ(lrf::read_json_file(detail_scores)["field_stamp"], lrf::file_stamp(refined + "/point_cloud.ply"));
  EXPECT_EQ(fs::last_write_time(dir / "run/stage3/decoder-ft.safetensors"), dec_time);
  // Fewer steps than were made, or another schedule, are refused.
  other.refine.steps = 4;
  msg = error_of([&] { lrf::run_pipeline(other); });
  EXPECT_NE(msg.find("the refined field in this folder was made with other settings"), std::string::npos) << msg;
  EXPECT_NE(msg.find("steps (5 vs 4)"), std::string::npos) << msg;
  other.refine.steps = 6;
  other.refine.lr_final = 0.5;
  msg = error_of([&] { lrf::run_pipeline(other); });
  EXPECT_NE(msg.find("the refined field in this folder was made with other settings"), std::string::npos) << msg;
}

// --shard i/n: two shards split the per-scene steps between them (each field fitted by one of them), leave
// what needs Stage I to the unsharded command, which reuses every field they fitted and writes the tables.
TEST(Pipeline, ShardsSplitThePerSceneStepsAndThePlainCommandFinishes) {
  lrf::test::TempDir dir("pipeline_shards");
  lrf::PipelineOptions o = tiny_pipeline(dir / "run");
  std::vector<std::string> done;
  for (const char* shard : {"0/2", "1/2"}) {
    lrf::PipelineOptions s = o;
    lrf::parse_shard(shard, &s);
    nlohmann::json r = lrf::run_pipeline(s);
    for (const auto& unit : r["done"]) done.push_back(unit.get<std::string>());
    // Stage I is never a shard's: the units that need it are left.
    EXPECT_FALSE(r["left"].empty()) << shard;
  }
  std::sort(done.begin(), done.end());
  EXPECT_EQ(std::adjacent_find(done.begin(), done.end()), done.end()) << "a unit ran in both shards";
  EXPECT_FALSE(fs::exists(dir / "run/stage1"));
  EXPECT_FALSE(fs::exists(dir / "run/ablation.csv"));
  const std::string train = fs::path(o.train_scenes[0]).filename().string();
  const std::string eval = fs::path(o.eval_scenes[0]).filename().string();
  const std::vector<std::string> by_shards = {train + "-stock", eval + "-stock", eval + "-stock-refined",
                                              eval + "-rgb8", eval + "-rgb8mip", eval + "-rgb", eval + "-rgbmip"};
  std::map<std::string, fs::file_time_type> fitted;
  for (const auto& f : by_shards) {
    const std::string ply = dir / ("run/fields/" + f + "/point_cloud.ply");
    ASSERT_TRUE(fs::exists(ply)) << f;
    fitted[f] = fs::last_write_time(ply);
  }
  EXPECT_FALSE(fs::exists(dir / ("run/fields/" + train + "-ft")));

  lrf::run_pipeline(o);
  for (const auto& [f, time] : fitted) {
    EXPECT_EQ(fs::last_write_time(dir / ("run/fields/" + f + "/point_cloud.ply")), time) << f << " was fitted again";
  }
  const std::string csv = lrf::read_file(dir / "run/ablation.csv");
  for (const auto& row : lrf::ablation_rows()) EXPECT_NE(csv.find("," + row + ","), std::string::npos) << row;

  for (const char* bad : {"2/2", "1", "a/2", "-1/2", "0/0", "1/2x"}) {
    EXPECT_NE(error_of([&] { lrf::parse_shard(bad, &o); }).find("--shard"), std::string::npos) << bad;
  }
}

// The mean over the evaluation scenes: column by column, only for methods every scene has, and a score
// only where every scene has it.
TEST(PipelineMean, AveragesEachRowOverTheScenesThatAllHaveIt) {
  const std::vector<std::string> header = {"scene", "method", "psnr", "lpips"};
  const std::vector<lrf::Row> rows = {
      {"fern", "stock", 20.0, 0.3}, {"fern", "both", 22.0, lrf::Cell()}, {"fern", "rgb/8", 18.0, 0.5},
      {"room", "stock", 24.0, 0.1}, {"room", "both", 27.0, 0.2},
  };
  lrf::SceneMean mean = lrf::mean_over_scenes(header, rows, {"fern", "room"}, {"rgb/8", "stock", "both", "rgb"});
  ASSERT_EQ(mean.rows.size(), 2u);  // rgb/8 lacks room's row; rgb is no scene's row
  EXPECT_EQ(mean.rows[0][0].text, "mean");
  EXPECT_EQ(mean.rows[0][1].text, "stock");
  EXPECT_DOUBLE_EQ(mean.rows[0][2].number, 22.0);
  EXPECT_DOUBLE_EQ(mean.rows[0][3].number, 0.2);
  EXPECT_EQ(mean.rows[1][1].text, "both");
  EXPECT_DOUBLE_EQ(mean.rows[1][2].number, 24.5);
  EXPECT_TRUE(mean.rows[1][3].missing());
  EXPECT_EQ(mean.left_out, (std::vector<std::string>{"rgb/8: no row for room", "both: lpips missing for fern"}));

  // One scene: its rows are the mean; a score no scene has is missing without a note.
  mean = lrf::mean_over_scenes(header, {{"fern", "stock", 20.5, lrf::Cell()}}, {"fern"}, {"stock"});
  ASSERT_EQ(mean.rows.size(), 1u);
  EXPECT_DOUBLE_EQ(mean.rows[0][2].number, 20.5);
  EXPECT_TRUE(mean.rows[0][3].missing());
  EXPECT_TRUE(mean.left_out.empty());
}

// Scenes with resolutions of their own: PATH:--downscale=N reaches every field of that scene (and Stage I
// for a training scene), the record says what each scene was given and used, a folder made at another
// resolution is refused, and the mean rows average the scenes' rows.
TEST(Pipeline, PerSceneResolutionsReachEveryFieldAndTheMeanAveragesTheScenes) {
  lrf::test::TempDir dir("pipeline_per_scene");
  lrf::PipelineOptions o = tiny_pipeline(dir / "run");
  const std::string small = o.eval_scenes[0];                                      // 64x48
  const std::string large = lrf::test::synthetic_scene({8, "128x96", 3, 800});    // 128x96, halved
  const std::string train = o.train_scenes[0];
  o.train_scenes = {train + ":--downscale=1"};
  o.eval_scenes = {small, large + ":--downscale=2"};
  o.rgb_full = false;
  o.refine_rows = false;

  // Checked before any stage: a bad option, a missing scene, a downscale too large for the images.
  for (const auto& [bad, expected] : std::vector<std::pair<std::string, std::string>>{
           {large + ":--size=2", "--eval-scenes: scene '" + large + ":--size=2': unknown option '--size=2'"},
           {large + ":--downscale=two", "--downscale 'two' is not a whole number"},
           {large + "-missing:--downscale=2", large + "-missing: scene folder not found"},
           {large + ":--images=images_2", "image folder not found (--images=images_2 of '" + large + ":--images=images_2')"},
           {large + ":--downscale=4", large + ":--downscale=4: "}}) {
    lrf::PipelineOptions b = o;
    b.eval_scenes = {small, bad};
    const std::string msg = error_of([&] { lrf::run_pipeline(b); });
    EXPECT_NE(msg.find(expected), std::string::npos) << bad << ": " << msg;
    EXPECT_FALSE(fs::exists(dir / "run/stage1")) << bad;
  }
  lrf::PipelineOptions b = o;
  b.train_scenes = {train + ":--images"};
  EXPECT_NE(error_of([&] { lrf::run_pipeline(b); }).find("--train-scenes: scene '"), std::string::npos);

  const nlohmann::json record = lrf::run_pipeline(o);
  const std::string small_name = fs::path(small).filename().string(), large_name = fs::path(large).filename().string();
  for (const char* tag : {"stock", "ft", "rgb8"}) {
    const nlohmann::json halved = lrf::read_json_file(dir / ("run/fields/" + large_name + "-" + tag + "/config.json"));
    EXPECT_EQ(halved["downscale"], 2) << tag;
    EXPECT_EQ(halved["resolution"], (nlohmann::json{64, 48})) << tag;
    const nlohmann::json plain = lrf::read_json_file(dir / ("run/fields/" + small_name + "-" + tag + "/config.json"));
    EXPECT_EQ(plain["downscale"], 1) << tag;
    EXPECT_EQ(plain["resolution"], (nlohmann::json{64, 48})) << tag;
  }
  const nlohmann::json resolutions = record["options"]["scene_resolutions"];
  EXPECT_EQ(resolutions[large_name]["argument"], large + ":--downscale=2");
  EXPECT_EQ(resolutions[large_name]["given"]["downscale"], 2);
  EXPECT_EQ(resolutions[large_name]["used"]["downscale"], 2);
  EXPECT_EQ(resolutions[small_name]["given"]["downscale"], 0);
  EXPECT_EQ(resolutions[small_name]["used"]["downscale"], 1);
  // The training scene's own resolution reached Stage I (its record), and so its resume key.
  const nlohmann::json stage1 = lrf::read_json_file(dir / "run/stage1/encoder.json")["options"];
  EXPECT_EQ(stage1["scene_resolutions"], (nlohmann::json{{{"images", ""}, {"downscale", 1}}})) << stage1.dump();

  // Each row's mean (record, CSV, report) is the average of the two scenes' rows.
  const nlohmann::json& results = record["results"];
  const nlohmann::json& mean = record["mean"]["scores"];
  const std::string csv = lrf::read_file(dir / "run/ablation.csv");
  for (const char* row : {"rgb/8", "rgb/8-mip", "stock", "encoder", "decoder", "both"}) {
    ASSERT_TRUE(mean.contains(row)) << row << " " << mean.dump();
    for (const char* metric : {"psnr", "ssim", "ms_ssim", "flip"}) {
      const nlohmann::json& a = results[small_name][row][metric];
      const nlohmann::json& b = results[large_name][row][metric];
      if (a.is_null() || b.is_null()) {  // a score these tiny views are too small for (MS-SSIM's scales)
        EXPECT_TRUE(mean[row][metric].is_null()) << row << " " << metric;
        continue;
      }
      EXPECT_NEAR(mean[row][metric].get<double>(), (a.get<double>() + b.get<double>()) / 2, 1e-9) << row << " " << metric;
    }
    EXPECT_TRUE(mean[row]["psnr"].is_number() && mean[row]["flip"].is_number()) << row << " " << mean[row].dump();
    EXPECT_NE(csv.find("\nmean," + std::string(row) + ","), std::string::npos) << row;
  }
  EXPECT_TRUE(record["mean"]["left_out"].empty()) << record["mean"].dump();
  EXPECT_NE(lrf::read_file(dir / "run/report.html").find("Mean over 2 evaluation scenes"), std::string::npos);
  EXPECT_NE(lrf::read_file(dir / "run/ablation.md").find("| mean "), std::string::npos);

  // The same folder with the scene at another resolution is refused, not reused.
  b = o;
  b.eval_scenes = {small, large};
  std::string msg = error_of([&] { lrf::run_pipeline(b); });
  EXPECT_NE(msg.find("the field in this folder was made with other settings"), std::string::npos) << msg;
  EXPECT_NE(msg.find("downscale (2 vs 1)"), std::string::npos) << msg;
  // So is Stage I, when a training scene loses its own resolution.
  b = o;
  b.train_scenes = {train};
  msg = error_of([&] { lrf::run_pipeline(b); });
  EXPECT_NE(msg.find("the Stage I encoder in this folder was made with other settings"), std::string::npos) << msg;
  EXPECT_NE(msg.find("scene_resolutions"), std::string::npos) << msg;
}

// The command line: the help shows the syntax, and a scene argument lrf cannot parse is a usage error
// (exit status 2) before anything is written.
TEST(Pipeline, CommandLineTakesScenesWithTheirOwnResolution) {
  const auto help = lrf::test::run_lrf("pipeline --help");
  EXPECT_EQ(help.exit_code, 0) << help.output;
  EXPECT_NE(help.output.find("PATH:--images=DIR"), std::string::npos) << help.output;
  EXPECT_NE(help.output.find("PATH:--downscale=N"), std::string::npos) << help.output;

  lrf::test::TempDir dir("pipeline_cli_scenes");
  const std::string scene = lrf::test::synthetic_scene(), other = lrf::test::synthetic_scene({8, "64x48", 11, 800});
  auto r = lrf::test::run_lrf("pipeline --train-scenes '" + scene + "' --eval-scenes '" + other +
                              ":--downscale=2x' -o '" + (dir / "run") + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--eval-scenes: scene '" + other + ":--downscale=2x': --downscale '2x' is not a whole number"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(dir / "run"));
}

TEST(Pipeline, RefusesAnEvaluationSceneThatIsAlsoATrainingScene) {
  lrf::test::TempDir dir("pipeline_overlap");
  lrf::PipelineOptions o = tiny_pipeline(dir / "run");
  o.eval_scenes = {o.train_scenes[0] + "/."};
  EXPECT_NE(error_of([&] { lrf::run_pipeline(o); }).find("both a training and an evaluation scene"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "run/stage1"));
}

// A folder whose pipeline.json predates the Lanczos undistortion holds stages fitted to other images.
TEST(Pipeline, RefusesAFolderMadeFromImagesOfAnotherLoader) {
  lrf::test::TempDir dir("pipeline_old_images");
  lrf::PipelineOptions o = tiny_pipeline(dir / "run");
  fs::create_directories(dir / "run");
  lrf::write_json_file(dir / "run/pipeline.json", {{"options", {{"field_iters", 60}}}});
  const std::string msg = error_of([&] { lrf::run_pipeline(o); });
  EXPECT_NE(msg.find("another version of lrf's image loader (view_images 1 vs 2)"), std::string::npos) << msg;
  EXPECT_FALSE(fs::exists(dir / "run/stage1"));
}

}  // namespace
