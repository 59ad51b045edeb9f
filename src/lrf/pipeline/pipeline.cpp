#include "lrf/pipeline/pipeline.h"

#include <filesystem>
#include <functional>
#include <map>
#include <set>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/core/folder_lock.h"
#include "lrf/core/log.h"
#include "lrf/core/paths.h"
#include "lrf/core/resources.h"
#include "lrf/core/run_info.h"
#include "lrf/eval/table.h"
#include "lrf/finetune/pair_batches.h"
#include "lrf/pipeline/pipeline_jobs.h"
#include "lrf/pipeline/pipeline_paths.h"
#include "lrf/pipeline/pipeline_plan.h"
#include "lrf/pipeline/pipeline_report.h"
#include "lrf/pipeline/pipeline_scenes.h"
#include "lrf/pipeline/pipeline_steps.h"
#include "lrf/pipeline/stage_times.h"
#include "lrf/scene/scene.h"

namespace fs = std::filesystem;

namespace lrf {

const std::vector<std::string>& ablation_rows() {
  static const std::vector<std::string> rows = {"rgb/8",   "rgb/8-mip", "rgb",          "rgb-mip",    "stock",
                                                "encoder", "decoder",   "both",         "stock+refine", "both+refine",
                                                "both+refine+detail"};
  return rows;
}


void check_no_overlap(const std::vector<std::string>& train_scenes, const std::vector<std::string>& eval_scenes) {
  std::set<std::string> train;
  for (const auto& t : train_scenes) train.insert(canonical_path(t));
  for (const auto& e : eval_scenes) {
    if (train.count(canonical_path(e))) {
      fail(e, "is both a training and an evaluation scene; evaluation scenes must be unseen");
    }
  }
}

void parse_shard(const std::string& text, PipelineOptions* options) {
  const size_t slash = text.find('/');
  int i = -1, n = 0;
  try {
    size_t used_i = 0, used_n = 0;
    if (slash != std::string::npos) {
      i = std::stoi(text.substr(0, slash), &used_i);
      n = std::stoi(text.substr(slash + 1), &used_n);
    }
    if (used_i != slash || used_n != text.size() - slash - 1) n = 0;
  } catch (const std::exception&) {
    n = 0;
  }
  if (n < 1 || i < 0 || i >= n) fail_usage("--shard '" + text + "': give i/n with 0 <= i < n (e.g. 0/2 and 1/2)");
  options->shard_index = i;
  options->shard_count = n;
}

namespace {

// The training scenes' fields by encoder: "stock" and "ft" (Stage I's), what each Stage III decoder learns from.
std::map<std::string, std::vector<std::string>> training_fields(const PipelineScenes& scenes,
                                                                 const PipelinePaths& paths) {
  std::map<std::string, std::vector<std::string>> fields;
  for (const auto& s : scenes.train) {
    fields["stock"].push_back(paths.field(s, "stock"));
    fields["ft"].push_back(paths.field(s, "ft"));
  }
  return fields;
}

// What a unit needs that is not finished yet, in words ("" when it can run).
std::string missing(const UnitNeeds& needs, const UnitNeeds& ready) {
  std::string m;
  if (needs.encoder && !ready.encoder) m = "the Stage I encoder";
  if (needs.decoder_stock && !ready.decoder_stock) m += (m.empty() ? "" : " and ") + std::string("the Stage III stock decoder");
  if (needs.decoder_ft && !ready.decoder_ft)
    m += (m.empty() ? "" : " and ") + std::string("the Stage III decoder of the Stage I fields");
  return m;
}

// One shard's share of the per-scene units (see run_pipeline in pipeline.h): every n-th of the plan, less
// those that need a stage the unsharded command makes.
nlohmann::json run_shard(int index, int count, const PipelineJobs& jobs, const PipelineScenes& scenes,
                         const PipelinePaths& paths) {
  const std::string me = "shard " + std::to_string(index) + "/" + std::to_string(count);
  const auto fields = training_fields(scenes, paths);
  const UnitNeeds ready{
      encoder_finished(jobs.stage1),
      decoder_finished(decoder_options(jobs.stage3, fields.at("stock"), "", paths.decoder("stock"))),
      decoder_finished(decoder_options(jobs.stage3, fields.at("ft"), paths.encoder(), paths.decoder("ft")))};
  std::map<std::string, EvaluatedScene> scored;  // the tables are the unsharded command's
  std::vector<PipelineUnit> units = training_field_units(jobs, scenes, paths);
  for (PipelineUnit& u : evaluation_units(jobs, scenes, paths, &scored)) units.push_back(std::move(u));
  nlohmann::json done = nlohmann::json::array(), left = nlohmann::json::array();
  for (size_t i = 0; i < units.size(); ++i) {
    if (static_cast<int>(i % static_cast<size_t>(count)) != index) continue;
    const std::string needs = missing(units[i].needs, ready);
    if (!needs.empty()) {
      log_info(me + ": left " + units[i].name + " for later: it needs " + needs);
      left.push_back(units[i].name + ": needs " + needs + " (run the unsharded command)");
      continue;
    }
    log_info("== " + me + ": " + units[i].name);
    units[i].work();
    done.push_back(units[i].name);
  }
  log_info(me + ": " + std::to_string(done.size()) + " unit(s) done, " + std::to_string(left.size()) +
           " left for the unsharded command");
  return {{"shard", me}, {"done", done}, {"left", left}};
}

// Every step of a pipeline folder was fitted to the images of the loader that first wrote its records
// (pipeline.json, and one per few-shot protocol; records without the entry are from loader 1); steps made
// from other images are not mixed in.
void require_same_view_images(const PipelinePaths& paths) {
  const PipelinePaths full_protocol{paths.root, ""};
  const std::set<std::string> records = {full_protocol.output("pipeline", "json"), paths.output("pipeline", "json")};
  for (const std::string& record : records) {  // one file when this is the full protocol
    if (!fs::exists(record)) continue;
    const int recorded = read_json_file(record).value("options", nlohmann::json::object()).value("view_images", 1);
    if (recorded != kViewImagesVersion) {
      fail(record, "this folder's stages were fitted to images made by another version of lrf's image loader "
                   "(view_images " + std::to_string(recorded) + " vs " + std::to_string(kViewImagesVersion) +
                   "): use another output folder");
    }
  }
}

// Wall time per stage (stage_times.h), from the records of the finished steps.
StageTimes stage_times_of(const PipelineJobs& jobs, const PipelineScenes& scenes, const PipelinePaths& paths,
                          const std::map<std::string, std::vector<std::string>>& train_fields) {
  StageTimes times;
  times.add("Stage I", "encoder, on " + std::to_string(scenes.train.size()) + " training scene(s)", 1,
            finetune_record_seconds(finetune_record_path(paths.encoder())));
  double fields = 0;
  int count = 0;
  for (const auto& [tag, dirs] : train_fields) {
    for (const auto& dir : dirs) {
      fields += field_run_seconds(dir);
      ++count;
    }
  }
  times.add("Stage II", "training scenes' latent fields (stock and Stage I encoder)", count, fields);
  times.add("Stage III", "decoders on those fields (stock and Stage I)", 2,
            finetune_record_seconds(decoder_record_path(paths.decoder("stock"))) +
                finetune_record_seconds(decoder_record_path(paths.decoder("ft"))));
  for (const auto& s : scenes.eval) {
    const std::string name = paths.eval_label(s);
    times.add("Stage II", name + ": latent fields (stock and Stage I encoder)", 2,
              field_run_seconds(paths.eval_field(s, "stock")) + field_run_seconds(paths.eval_field(s, "ft")));
    if (jobs.refine_rows) {
      times.add("refinement", name + ": the stock+refine and both+refine fields", 2,
                field_run_seconds(paths.eval_field(s, "stock-refined")) +
                    field_run_seconds(paths.eval_field(s, "ft-refined")));
    }
    if (!jobs.baselines.empty()) {
      double rgb = 0;
      std::string rows;
      for (const RgbBaseline& b : jobs.baselines) {
        rgb += field_run_seconds(paths.eval_field(s, b.tag));
        rows += std::string(rows.empty() ? "" : ", ") + b.row;
      }
      times.add("baselines", name + ": RGB fields (" + rows + ")", static_cast<int>(jobs.baselines.size()), rgb);
    }
  }
  return times;
}

}  // namespace
namespace {

// What pipeline.json records of the request: the scenes with their resolutions and every setting that
// decides a result.
nlohmann::json pipeline_inputs(const PipelineOptions& o, const PipelineScenes& scenes) {
  nlohmann::json inputs = {{"train_scenes", nlohmann::json::array()},
                           {"eval_scenes", nlohmann::json::array()},
                           {"autoencoder", o.autoencoder},
                           {"max_side", o.max_side},
                           {"field_iters", o.field_iters},
                           {"stage3_steps", o.stage3.steps},
                           {"refine", refine_options_json(o.refine)},
                           {"refine_rows", o.refine_rows},
                           {"rgb_full", o.rgb_full},
                           {"stage1", encoder_finetune_options_json(o.stage1)},
                           {"seed", o.seed},
                           {"eval_train_views", o.eval_train_views},
                           {"view_images", kViewImagesVersion}};
  // Recorded only when used, so that older records match.
  if (o.stage3.lambda_ssim != 0) inputs["stage3_lambda_ssim"] = o.stage3.lambda_ssim;
  if (o.stage3.weight_roundtrip != 0) inputs["stage3_weight_roundtrip"] = o.stage3.weight_roundtrip;
  for (const auto& s : scenes.train) inputs["train_scenes"].push_back(canonical_path(s));
  for (const auto& s : scenes.eval) inputs["eval_scenes"].push_back(canonical_path(s));
  // Each scene's resolution: the options given after its folder, and the image folder and downscale used.
  inputs["scene_resolutions"] = nlohmann::json::object();
  for (const auto* list : {&scenes.train, &scenes.eval}) {
    for (const auto& s : *list) {
      inputs["scene_resolutions"][scene_name(s)] = {{"argument", scenes.argument.at(s)},
                                                    {"given", scenes.given.at(s).json()},
                                                    {"used", scenes.used.at(s).json()}};
    }
  }
  return inputs;
}

// The training stages' artefacts: Stage I's encoder, the training scenes' fields by encoder ("stock",
// "ft"), and the Stage III decoder fine-tuned on each set.
struct TrainedStages {
  std::string encoder;
  std::map<std::string, std::vector<std::string>> fields;
};

// Stage I, then Stage II on the training scenes with both encoders, then Stage III on each set.
TrainedStages train_stages(const PipelineJobs& jobs, const PipelineScenes& scenes, const PipelinePaths& paths) {
  ensure_encoder(jobs.stage1);
  TrainedStages trained;
  trained.encoder = jobs.stage1.out;
  for (const PipelineUnit& unit : training_field_units(jobs, scenes, paths)) unit.work();
  trained.fields = training_fields(scenes, paths);
  ensure_decoder(decoder_options(jobs.stage3, trained.fields.at("stock"), "", paths.decoder("stock")));
  ensure_decoder(decoder_options(jobs.stage3, trained.fields.at("ft"), trained.encoder, paths.decoder("ft")));
  return trained;
}

// What each stage was trained on, from the stages' own records, checked to hold no evaluation scene.
nlohmann::json trained_on(const TrainedStages& trained, const PipelineScenes& scenes) {
  nlohmann::json on = {{"stage1", read_json_file(finetune_record_path(trained.encoder))["options"]["scenes"]},
                       {"stage3_stock", field_scenes(trained.fields.at("stock"))},
                       {"stage3_ft", field_scenes(trained.fields.at("ft"))}};
  for (auto& [stage, used] : on.items()) {
    std::vector<std::string> list;
    for (const auto& s : used) list.push_back(s.get<std::string>());
    check_no_overlap(list, scenes.eval);
  }
  return on;
}

// The test views' photographs of an evaluation scene at its resolution, and that resolution in words.
void add_photos(const std::string& scene_root, const SceneResolution& resolution, EvaluatedScene* scene) {
  SceneOptions so;
  so.images_dir = resolution.images;
  so.downscale = resolution.downscale;
  so.crop_to_multiple_of_8 = true;
  const Scene scene_data = load_scene(scene_root, so);
  if (!scene_data.views.empty()) {
    const Camera& camera = scene_data.views.front().camera;
    scene->resolution = scene->label + " " + (so.images_dir.empty() ? "default images" : so.images_dir) +
                        " downscaled " + std::to_string(so.downscale) + "x to " + std::to_string(camera.width) + "x" +
                        std::to_string(camera.height);
  }
  for (int i : scene_data.test_indices)
    scene->photos.push_back({scene_data.views[static_cast<size_t>(i)].name, scene_data.load_image(i)});
}

}  // namespace

nlohmann::json run_pipeline(const PipelineOptions& o) {
  if (o.train_scenes.empty() || o.eval_scenes.empty()) fail("pipeline: give --train-scenes and --eval-scenes");
  if (o.out.empty()) fail("pipeline: no output folder (-o)");
  // Every scene and its resolution, checked before any stage (this reads each scene's cameras).
  const PipelineScenes scenes = resolve_pipeline_scenes(o.train_scenes, o.eval_scenes, o.max_side);
  for (const auto* list : {&scenes.train, &scenes.eval}) {
    for (const auto& scene : *list) refuse_output_over_input(o.out, scene, "a scene folder");
  }
  const PipelinePaths paths{o.out, protocol_suffix(o.eval_train_views)};
  require_same_view_images(paths);
  fs::create_directories(o.out);
  // Shards share the folder with each other (each artefact is locked by the job writing it) and leave the
  // record, the tables and the report to the unsharded command.
  const PipelineJobs jobs = pipeline_jobs(o, scenes, paths);
  if (o.shard_count > 1) return run_shard(o.shard_index, o.shard_count, jobs, scenes, paths);
  const Stopwatch session;
  const FolderLock lock(o.out);  // the stages below take their own locks on their own outputs
  nlohmann::json record = run_record(pipeline_inputs(o, scenes));
  const std::string record_path = paths.output("pipeline", "json");
  write_json_file(record_path, record);

  const TrainedStages trained = train_stages(jobs, scenes, paths);
  record["trained_on"] = trained_on(trained, scenes);
  record["artifacts"] = {{"encoder", trained.encoder},
                         {"decoder_stock", paths.decoder("stock")},
                         {"decoder_ft", paths.decoder("ft")},
                         {"train_fields", trained.fields}};
  write_json_file(record_path, record);

  std::map<std::string, EvaluatedScene> scored;
  for (const PipelineUnit& unit : evaluation_units(jobs, scenes, paths, &scored)) unit.work();
  std::vector<EvaluatedScene> evaluated;
  for (const auto& s : scenes.eval) {
    EvaluatedScene& scene = scored[s];
    scene.label = paths.eval_label(s);
    add_photos(s, scenes.used.at(s), &scene);
    evaluated.push_back(std::move(scene));
  }
  const StageTimes times = stage_times_of(jobs, scenes, paths, trained.fields);
  const ReportTable stage_table = times.table();
  write_table_csv(paths.output("stages", "csv"), stage_table.header, stage_table.rows);
  write_table_markdown(paths.output("stages", "md"), stage_table.header, stage_table.rows);
  const AblationRecord ablation = write_ablation(jobs, scenes, paths, evaluated, stage_table);

  record["results"] = ablation.results;
  record["mean"] = ablation.mean;
  record["table"] = paths.output("ablation", "md");  // the protocol's own table (ablation-Kviews.md for K views)
  record["stage_seconds"] = times.json();
  record["wall_seconds_this_session"] = session.seconds();
  write_json_file(record_path, record);
  log_info("wrote " + paths.output("ablation", "md") + " and " + paths.output("report", "html"));
  return record;
}

}  // namespace lrf
