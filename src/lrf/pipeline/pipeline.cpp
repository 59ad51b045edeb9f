#include "lrf/pipeline/pipeline.h"

#include <chrono>
#include <functional>
#include <filesystem>
#include <map>
#include <optional>
#include <set>

#include "lrf/core/atomic_file.h"
#include "lrf/core/cache_key.h"
#include "lrf/core/error.h"
#include "lrf/core/paths.h"
#include "lrf/core/folder_lock.h"
#include "lrf/core/image_io.h"
#include "lrf/core/log.h"
#include "lrf/core/run_info.h"
#include "lrf/detail/detail_eval.h"
#include "lrf/eval/report.h"
#include "lrf/eval/table.h"
#include "lrf/rgb/rgb_eval.h"
#include "lrf/rgb/rgb_train_run.h"
#include "lrf/scene/scene.h"
#include "lrf/latent/latent_cache.h"
#include "lrf/latent/latent_run.h"
#include "lrf/points/initial_points.h"
#include "lrf/refine/refine_folder.h"
#include "lrf/finetune/decoder_finetune.h"
#include "lrf/finetune/pair_batches.h"
#include "lrf/pipeline/pipeline_scenes.h"
#include "lrf/pipeline/scene_mean.h"
#include "lrf/pipeline/stage_times.h"
#include "lrf/scene/scene_spec.h"
#include "lrf/splat/run/train_run.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

std::string scene_name(const std::string& root) { return fs::path(canonical_path(root)).filename().string(); }

// Where each artefact of a pipeline folder lives. Stage I, Stage III and the training scenes' fields are
// shared by every evaluation protocol; the evaluation scenes' fields, scores and the tables carry the
// protocol in their names ("" for every training view, "-3views" for the 3-view split), so the few-shot
// table is made beside the full one from the same Stage I and Stage III.
struct Paths {
  std::string root;
  std::string protocol;  // protocol_suffix(eval_train_views)
  std::string field(const std::string& scene, const std::string& tag) const {
    return (fs::path(root) / "fields" / (scene_name(scene) + "-" + tag)).string();
  }
  std::string eval_field(const std::string& scene, const std::string& tag) const {
    return (fs::path(root) / "fields" / (eval_label(scene) + "-" + tag)).string();
  }
  std::string encoder() const { return (fs::path(root) / "stage1" / "encoder.safetensors").string(); }
  std::string decoder(const std::string& tag) const {
    return (fs::path(root) / "stage3" / ("decoder-" + tag + ".safetensors")).string();
  }
  std::string eval(const std::string& scene, const std::string& row) const {
    return (fs::path(root) / "eval" / eval_label(scene) / row).string();
  }
  // An evaluation scene's name in folders and tables: its folder name and the protocol.
  std::string eval_label(const std::string& scene) const { return scene_name(scene) + protocol; }
  // A table, report or record of this protocol: DIR/<stem><protocol>.<extension>.
  std::string output(const std::string& stem, const std::string& extension) const {
    return (fs::path(root) / (stem + protocol + "." + extension)).string();
  }
};

std::string protocol_suffix(int train_views) {
  return train_views > 0 ? "-" + std::to_string(train_views) + "views" : std::string();
}

// Refuses to reuse a finished step of the pipeline that was made with other settings than this run's,
// naming each setting of `wanted` that the recorded ones lack or differ in.
void require_same_settings(const std::string& record, const nlohmann::json& recorded, const nlohmann::json& wanted,
                           const std::string& what, const std::string& folder) {
  const std::string differ = differing_settings(recorded, wanted);
  if (!differ.empty()) {
    fail(record, what + " in this folder was made with other settings than the pipeline's:" + differ +
                     "; use another output folder or remove " + folder);
  }
}

// The settings that decide a field: scene, resolution (image folder and downscale), length, seed, (latent)
// the autoencoder's identity and, for a K-view split, the track rule its initial points were triangulated
// with (none: the scene's own points).
nlohmann::json field_settings(const std::string& scene, const std::string& images, int downscale, int train_views,
                              int64_t iters, uint64_t seed, const std::string& autoencoder_id,
                              const nlohmann::json& min_track_length) {
  nlohmann::json j = {{"scene", canonical_path(scene)}, {"images", images}, {"downscale", downscale},
                      {"few_shot_views", train_views}, {"iters", iters}, {"seed", seed}};
  if (!autoencoder_id.empty()) j["autoencoder_identity"] = autoencoder_id;
  if (train_views > 0 && !min_track_length.is_null()) j["initial_points_min_track_length"] = min_track_length;
  return j;
}

nlohmann::json wanted_field_settings(const std::string& scene, const SceneResolution& resolution, int train_views,
                                     const PipelineOptions& o, const std::string& autoencoder_id) {
  // The pipeline's fields always start from `auto` points.
  const std::optional<int> rule = few_shot_track_rule("auto", train_views);
  return field_settings(scene, resolution.images, resolution.downscale, train_views, o.field_iters, o.seed,
                        autoencoder_id, rule ? nlohmann::json(*rule) : nlohmann::json());
}

// A record without the rule (written before it was recorded) gives null: the setting is then missing.
nlohmann::json recorded_min_track_length(const nlohmann::json& config) {
  const nlohmann::json init = config.value("init_points", nlohmann::json::object());
  if (!init.is_object()) return nullptr;
  return init.value("triangulation", nlohmann::json::object()).value("min_track_length", nlohmann::json());
}

// True if DIR holds a finished field made with these settings; throws if it holds one made with others.
bool reusable_field(const std::string& dir, const nlohmann::json& wanted) {
  if (!splat::run_finished(dir)) return false;
  const std::string record = (fs::path(dir) / "config.json").string();
  const nlohmann::json config = read_json_file(record);
  const nlohmann::json& options = config.at("options");
  const nlohmann::json recorded = field_settings(config.value("scene", std::string()),
                                                 config.value("images", std::string()), config.value("downscale", 0),
                                                 config.value("few_shot_views", 0),
                                                 options.value("iters", int64_t(0)), options.value("seed", uint64_t(0)),
                                                 config.value("autoencoder_identity", std::string()),
                                                 recorded_min_track_length(config));
  require_same_settings(record, recorded, wanted, "the field", dir);
  log_info("reusing field " + dir);
  return true;
}

// The recorded options of a fine-tuning step, without the checkpoint interval, which does not change the result.
nlohmann::json finetune_settings(nlohmann::json options) {
  options.erase("checkpoint_every");
  // Stage I records its scenes' own resolutions only when some scene has them (so that records from before
  // they existed still match); without them every scene is at its default, which is compared as null.
  if (!options.contains("scene_resolutions")) options["scene_resolutions"] = nullptr;
  return options;
}

void ensure_latent_field(const PipelineOptions& o, const std::string& scene, const SceneResolution& resolution,
                         int train_views, const std::string& dir, const std::string& encoder) {
  if (reusable_field(dir, wanted_field_settings(scene, resolution, train_views, o,
                                                autoencoder_identity(o.autoencoder, encoder)))) {
    return;
  }
  LatentTrainOptions l;
  l.scene = scene;
  l.out = dir;
  l.scene_options.images_dir = resolution.images;
  l.scene_options.downscale = resolution.downscale;
  l.scene_options.train_views = train_views;
  l.autoencoder = o.autoencoder;
  l.encoder = encoder;
  l.cache_dir = o.cache_dir;
  l.iters = o.field_iters;
  l.seed = o.seed;
  l.resume = fs::exists(splat::checkpoint_path(dir));
  l.force = !l.resume;
  log_info("== latent field " + dir + (l.resume ? " (resuming)" : "") + ": " + std::to_string(l.iters) +
           " steps on the " + (encoder.empty() ? "stock" : "Stage I") + " encoder's latents of " + scene +
           " (" + (resolution.images.empty() ? "images" : resolution.images) + " downscaled " +
           std::to_string(resolution.downscale) + "x)");
  train_latent_field(l);
}

// An RGB baseline: at latent resolution (factor 8) or full resolution (1), with or without Mip filters.
void ensure_rgb_field(const PipelineOptions& o, const std::string& scene, const SceneResolution& resolution,
                      const std::string& dir, int factor, bool mip) {
  if (reusable_field(dir, wanted_field_settings(scene, resolution, o.eval_train_views, o, ""))) return;
  RgbTrainOptions b;
  b.scene = scene;
  b.scene_options.images_dir = resolution.images;
  b.scene_options.downscale = resolution.downscale;
  b.scene_options.train_views = o.eval_train_views;
  b.scene_options.crop_to_multiple_of_8 = true;  // the latent fields' views
  b.out = dir;
  b.factor = factor;
  b.iters = o.field_iters;
  b.mip = mip;
  b.seed = o.seed;
  b.resume = fs::exists(splat::checkpoint_path(dir));
  b.force = !b.resume;
  b.task = std::string("train-rgb") + (factor == 1 ? "" : "/" + std::to_string(factor)) + (mip ? "-mip" : "");
  log_info("== RGB field " + dir + (b.resume ? " (resuming)" : "") + ": " + std::to_string(b.iters) + " steps on " +
           scene + "'s views" + (factor > 1 ? " reduced " + std::to_string(factor) + "x" : "") +
           (mip ? ", with Mip-Splatting's filters" : ""));
  train_rgb_field(b);
}

// The RGB rows are scored as lrf eval scores an RGB run.
RgbEvalOptions rgb_eval_options(const PipelineOptions& o) {
  RgbEvalOptions e;
  e.lpips_weights = o.lpips_weights;
  return e;
}

// A field refined through `decoder` (refine_folder.h: reused, continued to more steps, resumed or made).
void refine_eval_field(const PipelineOptions& o, const std::string& field, const std::string& decoder,
                       const std::string& dir) {
  RefineOptions r = o.refine;
  r.run = field;
  r.out = dir;
  r.decoder = decoder;
  r.seed = o.seed;
  r.cache_dir = o.cache_dir;
  log_info("== refinement " + dir + ": up to " + refine_length_text(r) + " of " + field +
           " through its decoder (a finished one is reused)");
  ensure_refined_field(r, "the refined field", "use another output folder or remove " + dir, false);
}

EncoderFinetuneOptions encoder_options(const PipelineOptions& o, const PipelineScenes& scenes, const Paths& paths) {
  EncoderFinetuneOptions e = o.stage1;
  e.scenes = scenes.train;
  e.scene_resolutions.clear();
  if (scenes.any_given(scenes.train)) {
    for (const auto& s : scenes.train) e.scene_resolutions.push_back(scenes.given.at(s));
  }
  e.correspondence_files.clear();
  e.autoencoder = o.autoencoder;
  e.encoder.clear();
  e.out = paths.encoder();
  e.max_side = o.max_side;
  e.seed = o.seed;
  return e;
}

// True if Stage I finished with these options; throws if it finished with others.
bool encoder_finished(const EncoderFinetuneOptions& e) {
  const std::string record = finetune_record_path(e.out);
  if (!fs::exists(e.out) || !fs::exists(record)) return false;
  require_same_settings(record, finetune_settings(read_json_file(record).value("options", nlohmann::json::object())),
                        finetune_settings(encoder_finetune_options_json(e)), "the Stage I encoder",
                        fs::path(e.out).parent_path().string());
  return true;
}

void ensure_encoder(const PipelineOptions& o, const PipelineScenes& scenes, const Paths& paths) {
  EncoderFinetuneOptions e = encoder_options(o, scenes, paths);
  if (encoder_finished(e)) {
    log_info("reusing Stage I encoder " + e.out);
    return;
  }
  e.resume = fs::exists(finetune_checkpoint_path(e.out));
  e.force = !e.resume;
  log_info(std::string("== Stage I") + (e.resume ? " (resuming)" : "") + ": " + std::to_string(e.steps) +
           " steps of " + std::to_string(e.batch.pairs) + " view pairs in " + std::to_string(e.batch.crop) +
           "-pixel crops, on " + std::to_string(e.scenes.size()) + " training scene(s)");
  finetune_encoder(e);
}

DecoderFinetuneOptions decoder_options(const PipelineOptions& o, const std::vector<std::string>& fields,
                                       const std::string& encoder, const std::string& out) {
  DecoderFinetuneOptions d;
  d.fields = fields;
  d.autoencoder = o.autoencoder;
  d.encoder = encoder;
  d.out = out;
  d.steps = o.stage3_steps;
  if (o.stage3_lr > 0) d.lr = o.stage3_lr;
  if (o.stage3_crop > 0) d.crop = o.stage3_crop;
  d.lambda_ssim = o.stage3_lambda_ssim;
  d.weight_roundtrip = o.stage3_weight_roundtrip;
  d.seed = o.seed;
  return d;
}

// True if this Stage III decoder finished with these options; throws if it finished with others.
bool decoder_finished(const DecoderFinetuneOptions& d) {
  const std::string record = decoder_record_path(d.out);
  if (!fs::exists(d.out) || !fs::exists(record)) return false;
  require_same_settings(record, finetune_settings(read_json_file(record).value("options", nlohmann::json::object())),
                        finetune_settings(decoder_finetune_options_json(d)), "the Stage III decoder",
                        fs::path(d.out).parent_path().string());
  return true;
}

void ensure_decoder(const PipelineOptions& o, const std::vector<std::string>& fields, const std::string& encoder,
                    const std::string& out) {
  DecoderFinetuneOptions d = decoder_options(o, fields, encoder, out);
  if (decoder_finished(d)) {
    log_info("reusing Stage III decoder " + out);
    return;
  }
  d.resume = fs::exists(decoder_checkpoint_path(out));
  d.force = !d.resume;
  log_info("== Stage III " + out + (d.resume ? " (resuming)" : "") + ": " + std::to_string(d.steps) +
           " steps on " + std::to_string(d.fields.size()) + " field(s)");
  finetune_decoder(d);
}

// A row's finished scores, reused only if they hold every metric this version reports: rows scored before
// FLIP and MS-SSIM existed are scored again (rendering, not retraining).
std::optional<nlohmann::json> reusable_scores(const std::string& metrics) {
  if (!fs::exists(metrics)) return std::nullopt;
  nlohmann::json m = read_json_file(metrics);
  if (!m.contains("flip") || !m.contains("ms_ssim")) return std::nullopt;
  return m;
}

// A latent row's scores are kept apart from its field, so they are reused only while they belong to the
// field as it is now (a refined field continued to more steps is scored again).
nlohmann::json ensure_latent_eval(const PipelineOptions& o, const std::string& field, const std::string& decoder,
                                  const std::string& dir) {
  auto scores = reusable_scores((fs::path(dir) / "metrics.json").string());
  const std::string field_stamp = file_stamp((fs::path(field) / "point_cloud.ply").string());
  if (scores && scores->value("field_stamp", std::string()) == field_stamp) {
    return *scores;
  }
  LatentEvalOptions e;
  e.decoder = decoder;
  e.lpips_weights = o.lpips_weights;
  e.output_dir = dir;
  return evaluate_latent_run(field, e);
}

// The detail pass's row of a refined field: reused while the field and the pass's options are those it was
// scored with. `field_scores` (the field's own row) gives what the pass leaves as it was: the field's
// latent and round-trip PSNR, its training time and storage.
nlohmann::json ensure_detail_eval(const PipelineOptions& o, const std::string& field, const std::string& dir,
                                  const nlohmann::json& field_scores) {
  const std::string metrics = (fs::path(dir) / "metrics.json").string();
  auto scores = reusable_scores(metrics);
  const std::string field_stamp = file_stamp((fs::path(field) / "point_cloud.ply").string());
  const nlohmann::json request = detail::detail_options_json(o.detail);
  if (scores && scores->value("field_stamp", std::string()) == field_stamp &&
      scores->value("detail_request", nlohmann::json()) == request) {
    return *scores;
  }
  detail::DetailEvalOptions e;
  e.lpips_weights = o.lpips_weights;
  e.detail = o.detail;
  nlohmann::json m = detail::evaluate_with_detail(field, dir, e, &field_scores);
  m["field_stamp"] = field_stamp;
  m["detail_request"] = request;
  write_json_file(metrics, m);
  return m;
}

// The scenes a Stage III decoder was fine-tuned on, from its fields' recorded configurations.
std::vector<std::string> field_scenes(const std::vector<std::string>& fields) {
  std::vector<std::string> scenes;
  for (const auto& f : fields) {
    const nlohmann::json config = read_json_file((fs::path(f) / "config.json").string());
    scenes.push_back(canonical_path(config.value("scene", std::string())));
  }
  return scenes;
}

}  // namespace

const std::vector<std::string>& ablation_rows() {
  static const std::vector<std::string> rows = {"rgb/8",   "rgb/8-mip", "rgb",          "rgb-mip",    "stock",
                                                "encoder", "decoder",   "both",         "stock+refine", "both+refine",
                                                "both+refine+detail"};
  return rows;
}

namespace {
bool image_space_row(const std::string& row) { return row.rfind("rgb", 0) == 0; }

// The image-space baselines: row, field folder tag, resolution factor, Mip filters.
struct RgbBaseline {
  const char* row;
  const char* tag;
  int factor;
  bool mip;
};
const std::vector<RgbBaseline>& rgb_baselines() {
  static const std::vector<RgbBaseline> list = {{"rgb/8", "rgb8", 8, false}, {"rgb/8-mip", "rgb8mip", 8, true},
                                                {"rgb", "rgb", 1, false},     {"rgb-mip", "rgbmip", 1, true}};
  return list;
}
}  // namespace

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

// One shard's share of the per-scene steps (see run_pipeline in pipeline.h).
nlohmann::json run_shard(const PipelineOptions& o, const PipelineScenes& scenes, const Paths& paths) {
  const auto& resolution = scenes.used;
  const std::string me = "shard " + std::to_string(o.shard_index) + "/" + std::to_string(o.shard_count);
  nlohmann::json done = nlohmann::json::array(), left = nlohmann::json::array();
  int unit = 0;
  // Runs `work` if unit number `unit` is this shard's; `work` returns what it left undone ("" if nothing).
  auto run_unit = [&](const std::string& name, const std::function<std::string()>& work) {
    if (unit++ % o.shard_count != o.shard_index) return;
    log_info("== " + me + ": " + name);
    const std::string undone = work();
    if (undone.empty()) {
      done.push_back(name);
    } else {
      log_info(me + ": left " + name + " for later: " + undone);
      left.push_back(name + ": " + undone);
    }
  };
  const std::string encoder = paths.encoder();
  const bool encoder_ready = encoder_finished(encoder_options(o, scenes, paths));
  std::vector<std::string> stock_fields, ft_fields;
  for (const auto& s : scenes.train) {
    stock_fields.push_back(paths.field(s, "stock"));
    ft_fields.push_back(paths.field(s, "ft"));
  }
  const bool decoder_stock_ready = decoder_finished(decoder_options(o, stock_fields, "", paths.decoder("stock")));
  const bool decoder_ft_ready = decoder_finished(decoder_options(o, ft_fields, encoder, paths.decoder("ft")));
  const std::string no_encoder = "needs the Stage I encoder (run the unsharded command)";

  for (const auto& s : scenes.train) {
    run_unit("field " + paths.field(s, "stock"), [&] {
      ensure_latent_field(o, s, resolution.at(s), 0, paths.field(s, "stock"), "");
      return std::string();
    });
    run_unit("field " + paths.field(s, "ft"), [&] {
      if (!encoder_ready) return no_encoder;
      ensure_latent_field(o, s, resolution.at(s), 0, paths.field(s, "ft"), encoder);
      return std::string();
    });
  }
  for (const auto& s : scenes.eval) {
    const std::string stock_field = paths.eval_field(s, "stock"), ft_field = paths.eval_field(s, "ft");
    run_unit("stock rows of " + paths.eval_label(s), [&] {
      ensure_latent_field(o, s, resolution.at(s), o.eval_train_views, stock_field, "");
      ensure_latent_eval(o, stock_field, "", paths.eval(s, "stock"));
      if (o.refine_rows) {
        const std::string refined = paths.eval_field(s, "stock-refined");
        refine_eval_field(o, stock_field, "", refined);
        ensure_latent_eval(o, refined, "", paths.eval(s, "stock+refine"));
      }
      if (!decoder_stock_ready) return std::string("the decoder row needs the Stage III stock decoder");
      ensure_latent_eval(o, stock_field, paths.decoder("stock"), paths.eval(s, "decoder"));
      return std::string();
    });
    run_unit("Stage I rows of " + paths.eval_label(s), [&] {
      if (!encoder_ready) return no_encoder;
      ensure_latent_field(o, s, resolution.at(s), o.eval_train_views, ft_field, encoder);
      ensure_latent_eval(o, ft_field, "", paths.eval(s, "encoder"));
      if (!decoder_ft_ready) return std::string("the both rows need the Stage III decoder of the Stage I fields");
      ensure_latent_eval(o, ft_field, paths.decoder("ft"), paths.eval(s, "both"));
      if (o.refine_rows) {
        const std::string refined = paths.eval_field(s, "ft-refined");
        refine_eval_field(o, ft_field, paths.decoder("ft"), refined);
        const nlohmann::json scores = ensure_latent_eval(o, refined, "", paths.eval(s, "both+refine"));
        if (o.detail_row) ensure_detail_eval(o, refined, paths.eval(s, "both+refine+detail"), scores);
      }
      return std::string();
    });
    if (!o.rgb_baseline) continue;
    for (const RgbBaseline& b : rgb_baselines()) {
      if (b.factor == 1 && !o.rgb_full) continue;
      run_unit(std::string(b.row) + " of " + paths.eval_label(s), [&] {
        const std::string rgb = paths.eval_field(s, b.tag);
        ensure_rgb_field(o, s, resolution.at(s), rgb, b.factor, b.mip);
        if (!reusable_scores((fs::path(rgb) / "metrics.json").string())) evaluate_rgb_run(rgb, rgb_eval_options(o));
        return std::string();
      });
    }
  }
  log_info(me + ": " + std::to_string(done.size()) + " unit(s) done, " + std::to_string(left.size()) +
           " left for the unsharded command");
  return {{"shard", me}, {"done", done}, {"left", left}};
}

// Every step of a pipeline folder was fitted to the images of the loader that first wrote its records
// (pipeline.json, and one per few-shot protocol; records without the entry are from loader 1); steps made
// from other images are not mixed in.
void require_same_view_images(const Paths& paths) {
  const Paths full_protocol{paths.root, ""};
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
StageTimes stage_times_of(const PipelineOptions& o, const PipelineScenes& scenes, const Paths& paths,
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
    if (o.refine_rows) {
      times.add("refinement", name + ": the stock+refine and both+refine fields", 2,
                field_run_seconds(paths.eval_field(s, "stock-refined")) +
                    field_run_seconds(paths.eval_field(s, "ft-refined")));
    }
    if (o.rgb_baseline) {
      double rgb = 0;
      std::string rows;
      int n = 0;
      for (const RgbBaseline& b : rgb_baselines()) {
        if (b.factor == 1 && !o.rgb_full) continue;
        rgb += field_run_seconds(paths.eval_field(s, b.tag));
        rows += std::string(rows.empty() ? "" : ", ") + b.row;
        ++n;
      }
      times.add("baselines", name + ": RGB fields (" + rows + ")", n, rgb);
    }
  }
  return times;
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
  const auto& resolution = scenes.used;
  const Paths paths{o.out, protocol_suffix(o.eval_train_views)};
  require_same_view_images(paths);
  if (o.shard_count > 1) {
    // Shards share the folder with each other (each artefact is locked by the job writing it) and leave
    // the record, the tables and the report to the unsharded command.
    fs::create_directories(o.out);
    return run_shard(o, scenes, paths);
  }
  const auto t0 = std::chrono::steady_clock::now();
  fs::create_directories(o.out);
  const FolderLock lock(o.out);  // the stages below take their own locks on their own outputs
  nlohmann::json inputs = {{"train_scenes", nlohmann::json::array()},
                           {"eval_scenes", nlohmann::json::array()},
                           {"autoencoder", o.autoencoder},
                           {"max_side", o.max_side},
                           {"field_iters", o.field_iters},
                           {"stage3_steps", o.stage3_steps},
                           {"refine", refine_options_json(o.refine)},
                           {"refine_rows", o.refine_rows},
                           {"rgb_full", o.rgb_full},
                           {"stage1", encoder_finetune_options_json(o.stage1)},
                           {"seed", o.seed},
                           {"eval_train_views", o.eval_train_views},
                           {"view_images", kViewImagesVersion}};
  // Recorded only when used, so that older records match.
  if (o.stage3_lambda_ssim != 0) inputs["stage3_lambda_ssim"] = o.stage3_lambda_ssim;
  if (o.stage3_weight_roundtrip != 0) inputs["stage3_weight_roundtrip"] = o.stage3_weight_roundtrip;
  for (const auto& s : scenes.train) inputs["train_scenes"].push_back(canonical_path(s));
  for (const auto& s : scenes.eval) inputs["eval_scenes"].push_back(canonical_path(s));
  // Each scene's resolution: the options given after its folder, and the image folder and downscale used.
  inputs["scene_resolutions"] = nlohmann::json::object();
  for (const auto* list : {&scenes.train, &scenes.eval}) {
    for (const auto& s : *list) {
      inputs["scene_resolutions"][scene_name(s)] = {{"argument", scenes.argument.at(s)},
                                                    {"given", scenes.given.at(s).json()},
                                                    {"used", resolution.at(s).json()}};
    }
  }
  nlohmann::json record = run_record(inputs);
  const std::string record_path = paths.output("pipeline", "json");
  write_json_file(record_path, record);

  // Stage I, then Stage II on the training scenes with both encoders, then Stage III on each set.
  ensure_encoder(o, scenes, paths);
  const std::string encoder = paths.encoder();
  std::map<std::string, std::vector<std::string>> train_fields;
  for (const auto& s : scenes.train) {
    for (const auto& [tag, enc] : {std::pair<std::string, std::string>{"stock", ""}, {"ft", encoder}}) {
      const std::string dir = paths.field(s, tag);
      ensure_latent_field(o, s, resolution.at(s), 0, dir, enc);  // Stage III learns from every view
      train_fields[tag].push_back(dir);
    }
  }
  ensure_decoder(o, train_fields["stock"], "", paths.decoder("stock"));
  ensure_decoder(o, train_fields["ft"], encoder, paths.decoder("ft"));

  // What each stage was trained on, from the stages' own records, checked against the evaluation scenes.
  nlohmann::json trained_on = {
      {"stage1", read_json_file(finetune_record_path(encoder))["options"]["scenes"]},
      {"stage3_stock", field_scenes(train_fields["stock"])},
      {"stage3_ft", field_scenes(train_fields["ft"])}};
  for (auto& [stage, used] : trained_on.items()) {
    std::vector<std::string> list;
    for (const auto& s : used) list.push_back(s.get<std::string>());
    check_no_overlap(list, scenes.eval);
  }
  record["trained_on"] = trained_on;
  record["artifacts"] = {{"encoder", encoder},
                         {"decoder_stock", paths.decoder("stock")},
                         {"decoder_ft", paths.decoder("ft")},
                         {"train_fields", train_fields}};
  write_json_file(record_path, record);

  // Evaluation scenes: fields with both encoders (and the rgb/8 baseline), decoded with both decoders.
  const std::vector<std::string> header = {"scene", "method",  "psnr",        "delta_psnr",    "ssim",
                                           "ms_ssim", "flip", "lpips", "latent_psnr", "roundtrip_psnr"};
  std::vector<Row> rows;
  ReportSpec spec;
  spec.title = "lrf pipeline: ablation";
  spec.max_image_side = 640;
  nlohmann::json results = nlohmann::json::object();
  std::vector<std::string> eval_labels;
  std::string resolutions;  // each evaluation scene's image folder and size, for the report's notes
  for (const auto& s : scenes.eval) {
    eval_labels.push_back(paths.eval_label(s));
    const std::string stock_field = paths.eval_field(s, "stock"), ft_field = paths.eval_field(s, "ft");
    ensure_latent_field(o, s, resolution.at(s), o.eval_train_views, stock_field, "");
    ensure_latent_field(o, s, resolution.at(s), o.eval_train_views, ft_field, encoder);
    std::map<std::string, nlohmann::json> m;
    std::map<std::string, std::string> image_dirs;
    if (o.rgb_baseline) {
      for (const RgbBaseline& b : rgb_baselines()) {
        if (b.factor == 1 && !o.rgb_full) continue;
        const std::string rgb = paths.eval_field(s, b.tag);
        ensure_rgb_field(o, s, resolution.at(s), rgb, b.factor, b.mip);
        const std::string metrics = (fs::path(rgb) / "metrics.json").string();
        auto scores = reusable_scores(metrics);
        m[b.row] = scores ? *scores : evaluate_rgb_run(rgb, rgb_eval_options(o));
        image_dirs[b.row] = (fs::path(rgb) / "eval").string();
      }
    }
    std::map<std::string, std::pair<std::string, std::string>> latent_rows = {
        {"stock", {stock_field, ""}},
        {"encoder", {ft_field, ""}},
        {"decoder", {stock_field, paths.decoder("stock")}},
        {"both", {ft_field, paths.decoder("ft")}}};
    if (o.refine_rows) {
      // Each refined field is decoded by the decoder it was refined through (recorded in its config).
      const std::string stock_refined = paths.eval_field(s, "stock-refined");
      const std::string ft_refined = paths.eval_field(s, "ft-refined");
      refine_eval_field(o, stock_field, "", stock_refined);
      refine_eval_field(o, ft_field, paths.decoder("ft"), ft_refined);
      latent_rows["stock+refine"] = {stock_refined, ""};
      latent_rows["both+refine"] = {ft_refined, ""};
    }
    for (const auto& [row, spec_pair] : latent_rows) {
      const std::string dir = paths.eval(s, row);
      m[row] = ensure_latent_eval(o, spec_pair.first, spec_pair.second, dir);
      image_dirs[row] = (fs::path(dir) / "eval").string();
    }
    if (o.refine_rows && o.detail_row) {
      const std::string dir = paths.eval(s, "both+refine+detail");
      m["both+refine+detail"] = ensure_detail_eval(o, latent_rows["both+refine"].first, dir, m["both+refine"]);
      image_dirs["both+refine+detail"] = (fs::path(dir) / "eval").string();
    }
    const double stock_psnr = m["stock"].value("psnr", 0.0);
    for (const auto& row : ablation_rows()) {
      if (!m.count(row)) continue;
      const auto& r = m[row];
      const bool latent = !image_space_row(row);
      rows.push_back({paths.eval_label(s), row, Cell::number_in(r, "psnr"),
                      r.contains("psnr") ? Cell(r["psnr"].get<double>() - stock_psnr) : Cell(),
                      Cell::number_in(r, "ssim"), Cell::number_in(r, "ms_ssim"), Cell::number_in(r, "flip"),
                      Cell::number_in(r, "lpips"),
                      latent ? Cell::number_in(r, "latent_psnr") : Cell(),
                      latent ? Cell::number_in(r, "roundtrip_psnr") : Cell()});
      results[paths.eval_label(s)][row] = {{"psnr", r.value("psnr", 0.0)},
                                     {"ssim", r.value("ssim", 0.0)},
                                     {"ms_ssim", r.value("ms_ssim", nlohmann::json())},
                                     {"flip", r.value("flip", nlohmann::json())},
                                     {"lpips", r.value("lpips", nlohmann::json())}};
    }
    // Report: every test view, ground truth then each row.
    SceneOptions so;
    so.images_dir = resolution.at(s).images;
    so.downscale = resolution.at(s).downscale;
    so.crop_to_multiple_of_8 = true;
    Scene scene = load_scene(s, so);
    if (!scene.views.empty()) {
      const Camera& camera = scene.views.front().camera;
      resolutions += std::string(resolutions.empty() ? "" : "; ") + paths.eval_label(s) + " " +
                     (so.images_dir.empty() ? "default images" : so.images_dir) + " downscaled " +
                     std::to_string(so.downscale) + "x to " + std::to_string(camera.width) + "x" +
                     std::to_string(camera.height);
    }
    for (int i : scene.test_indices) {
      const View& v = scene.views[static_cast<size_t>(i)];
      ReportView rv;
      rv.name = paths.eval_label(s) + " / " + v.name;
      rv.ground_truth = {"ground truth", scene.load_image(i), {}};
      const std::string png = fs::path(v.name).stem().string() + ".png";
      for (const auto& row : ablation_rows()) {
        if (!image_dirs.count(row)) continue;
        const std::string path = (fs::path(image_dirs[row]) / png).string();
        ReportImage im{row, fs::exists(path) ? read_image_rgb(path) : cv::Mat(), {}};
        for (const auto& view : m[row].value("views", nlohmann::json::array())) {
          if (view.value("name", std::string()) == v.name) {
            im.numbers.push_back({"PSNR", Cell::number_in(view, "psnr")});
            im.numbers.push_back({"FLIP", Cell::number_in(view, "flip")});
          }
        }
        rv.methods.push_back(im);
      }
      spec.views.push_back(rv);
    }
  }
  // The mean over the evaluation scenes of every row (the paper's Table 1), below the per-scene rows,
  // and in the report as a table of its own.
  const SceneMean mean = mean_over_scenes(header, rows, eval_labels, ablation_rows());
  const std::string mean_title = "Mean over " + std::to_string(eval_labels.size()) + " evaluation scene" +
                                 (eval_labels.size() == 1 ? "" : "s");
  std::string mean_note;
  if (!mean.left_out.empty()) {
    mean_note = mean_title + " leaves out what a scene lacks: ";
    for (size_t i = 0; i < mean.left_out.size(); ++i) mean_note += (i ? "; " : "") + mean.left_out[i];
    mean_note += ".";
    log_info(mean_note);
  }
  // With one evaluation scene its mean is its own rows: shown once.
  const bool several_scenes = eval_labels.size() > 1;
  if (several_scenes) rows.insert(rows.end(), mean.rows.begin(), mean.rows.end());
  const std::vector<Better> better = {Better::none,   Better::none,  Better::higher, Better::higher, Better::higher,
                                      Better::higher, Better::lower, Better::lower,  Better::higher, Better::higher};
  write_table_csv(paths.output("ablation", "csv"), header, rows);
  write_file_atomic(paths.output("ablation", "md"), table_markdown(header, rows, paths.output("ablation", "md")) +
                                                        (mean_note.empty() ? "" : "\n" + mean_note + "\n"));
  spec.summary_header = header;
  spec.summary_rows = rows;
  spec.summary_better = better;
  ReportTable mean_table{mean_title, {header.begin() + 1, header.end()}, {}, {better.begin() + 1, better.end()}};
  for (const Row& r : mean.rows) mean_table.rows.push_back(Row(r.begin() + 1, r.end()));
  if (several_scenes) spec.tables.push_back(mean_table);
  std::string train_list, eval_list;
  for (const auto& s : scenes.train) train_list += (train_list.empty() ? "" : ", ") + scenes.argument.at(s);
  for (const auto& s : scenes.eval) eval_list += (eval_list.empty() ? "" : ", ") + scenes.argument.at(s);
  spec.notes.push_back("Training scenes (Stage I and Stage III): " + train_list + ". Evaluation scenes (unseen by both): " +
                       eval_list + ". Autoencoder " + o.autoencoder + "; " +
                       (o.max_side > 0 ? "every scene without a --downscale of its own downscaled so its longer side "
                                         "is at most " + std::to_string(o.max_side) + " px"
                                       : std::string("every scene at its images' size unless it gives a --downscale")) +
                       "; latent fields of " + std::to_string(o.field_iters) + " training steps.");
  if (!resolutions.empty()) spec.notes.push_back("Evaluated at: " + resolutions + ".");
  if (!mean_note.empty()) spec.notes.push_back(mean_note);
  if (o.eval_train_views > 0) {
    spec.notes.push_back("Few-shot (" + paths.protocol.substr(1) + " in the scene names): the evaluation scenes' fields "
                         "(latent, refined and RGB) trained on only " + std::to_string(o.eval_train_views) +
                         " views, evenly spaced over the non-test views; Stage I, Stage III and the training scenes' "
                         "fields are the folder's own, shared with its full-view table (ablation.csv).");
  }
  spec.notes.push_back("Rows as in the paper's Table 3: stock = latent field with the stock encoder, decoded by the stock "
                       "decoder; encoder = Stage I encoder; decoder = Stage III decoder fine-tuned on stock-encoder "
                       "fields; both = Stage I encoder and the decoder fine-tuned on its fields. stock+refine and "
                       "both+refine: those fields refined through their decoder against the scene's training images "
                       "(lrf refine: " + refine_description(o.refine) + "). Image-space baselines: rgb/8 and "
                       "rgb/8-mip = RGB 3DGS and Mip-Splatting trained at latent resolution (the paper's 3DGS/8 and "
                       "Mip-Splatting/8), rgb = RGB 3DGS at full resolution. \u0394 PSNR is against the stock row.");
  const StageTimes times = stage_times_of(o, scenes, paths, train_fields);
  const ReportTable stage_times = times.table();
  write_table_csv(paths.output("stages", "csv"), stage_times.header, stage_times.rows);
  write_table_markdown(paths.output("stages", "md"), stage_times.header, stage_times.rows);
  spec.tables.push_back(stage_times);
  write_html_report(paths.output("report", "html"), spec);
  record["results"] = results;
  nlohmann::json mean_scores = nlohmann::json::object();
  for (const Row& r : mean.rows) {
    for (size_t c = 2; c < header.size(); ++c) {
      mean_scores[r[1].text][header[c]] = r[c].missing() ? nlohmann::json() : nlohmann::json(r[c].number);
    }
  }
  record["mean"] = {{"scenes", eval_labels}, {"scores", mean_scores}, {"left_out", mean.left_out}};
  record["table"] = paths.output("ablation", "md");  // the protocol's own table (ablation-Kviews.md for K views)
  record["stage_seconds"] = times.json();
  record["wall_seconds_this_session"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  write_json_file(record_path, record);
  log_info("wrote " + paths.output("ablation", "md") + " and " + paths.output("report", "html"));
  return record;
}

}  // namespace lrf
