#include "lrf/pipeline/pipeline_steps.h"

#include <filesystem>
#include <functional>

#include "lrf/core/artefact.h"
#include "lrf/core/atomic_file.h"
#include "lrf/core/cache_key.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/paths.h"
#include "lrf/core/run_info.h"
#include "lrf/detail/detail_eval.h"
#include "lrf/finetune/pair_batches.h"
#include "lrf/latent/latent_cache.h"
#include "lrf/latent/latent_run.h"
#include "lrf/latent/latent_train_run.h"
#include "lrf/points/initial_points.h"
#include "lrf/refine/refine_folder.h"
#include "lrf/rgb/rgb_eval.h"
#include "lrf/rgb/rgb_train_run.h"
#include "lrf/splat/run/train_run.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {
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
                                     const SceneFitOptions& job, const std::string& autoencoder_id) {
  // The pipeline's fields always start from `auto` points.
  const std::optional<int> rule = few_shot_track_rule("auto", train_views);
  return field_settings(scene, resolution.images, resolution.downscale, train_views, job.iters, job.seed,
                        autoencoder_id, rule ? nlohmann::json(*rule) : nlohmann::json());
}

// A record without the rule (written before it was recorded) gives null: the setting is then missing.
nlohmann::json recorded_min_track_length(const nlohmann::json& config) {
  const nlohmann::json init = config.value("init_points", nlohmann::json::object());
  if (!init.is_object()) return nullptr;
  return init.value("triangulation", nlohmann::json::object()).value("min_track_length", nlohmann::json());
}

// A field's life in the pipeline folder: reused when finished with `wanted` (the settings that decide it).
ArtefactLife field_life(const std::string& dir, nlohmann::json wanted) {
  ArtefactLife life;
  life.what = "the field";
  life.record = (fs::path(dir) / "config.json").string();
  life.remedy = "use another output folder or remove " + dir;
  life.finished = [dir] { return splat::run_finished(dir); };
  life.recorded = [record = life.record] {
    const nlohmann::json config = read_json_file(record);
    const nlohmann::json& options = config.at("options");
    return field_settings(config.value("scene", std::string()), config.value("images", std::string()),
                          config.value("downscale", 0), config.value("few_shot_views", 0),
                          options.value("iters", int64_t(0)), options.value("seed", uint64_t(0)),
                          config.value("autoencoder_identity", std::string()), recorded_min_track_length(config));
  };
  life.wanted = std::move(wanted);
  life.resumable = [dir] { return fs::exists(splat::checkpoint_path(dir)); };
  return life;
}

// The recorded options of a fine-tuning step, without the checkpoint interval, which does not change the result.
nlohmann::json finetune_settings(nlohmann::json options) {
  options.erase("checkpoint_every");
  // Stage I records its scenes' own resolutions only when some scene has them (so that records from before
  // they existed still match); without them every scene is at its default, which is compared as null.
  if (!options.contains("scene_resolutions")) options["scene_resolutions"] = nullptr;
  return options;
}

// A fine-tuned encoder's or decoder's life: `out` and its run record, compared by their recorded options.
ArtefactLife finetune_life(const std::string& what, const std::string& out, const std::string& record,
                           const std::string& checkpoint, const nlohmann::json& options) {
  ArtefactLife life;
  life.what = what;
  life.record = record;
  life.remedy = "use another output folder or remove " + fs::path(out).parent_path().string();
  life.finished = [out, record] { return fs::exists(out) && fs::exists(record); };
  life.recorded = [record] {
    return finetune_settings(read_json_file(record).value("options", nlohmann::json::object()));
  };
  life.wanted = finetune_settings(options);
  life.resumable = [checkpoint] { return fs::exists(checkpoint); };
  return life;
}

ArtefactLife encoder_life(const EncoderFinetuneOptions& e) {
  return finetune_life("the Stage I encoder", e.out, finetune_record_path(e.out), finetune_checkpoint_path(e.out),
                       encoder_finetune_options_json(e));
}

ArtefactLife decoder_life(const DecoderFinetuneOptions& d) {
  return finetune_life("the Stage III decoder", d.out, decoder_record_path(d.out), decoder_checkpoint_path(d.out),
                       decoder_finetune_options_json(d));
}

// A job's artefact (`what`: a field, the Stage I encoder, a Stage III decoder): reused, or made by `run` with
// `control` (its job's options) set to resume or to start afresh.
void ensure_job_artefact(ArtefactLife life, const std::string& what, RunControl* control,
                         const std::function<void()>& run) {
  life.make = [control, &run](bool resume) {
    control->resume = resume;
    control->force = !resume;
    run();
  };
  if (ensure_artefact(life) == ArtefactFate::reused) log_info("reusing " + what + " " + control->out);
}

// A row's finished scores, reused only if they hold every metric this version reports: rows scored before
// FLIP and MS-SSIM existed are scored again (rendering, not retraining).
std::optional<nlohmann::json> reusable_scores(const std::string& metrics) {
  if (!fs::exists(metrics)) return std::nullopt;
  nlohmann::json m = read_json_file(metrics);
  if (!m.contains("flip") || !m.contains("ms_ssim")) return std::nullopt;
  return m;
}

// A row's scores are kept apart from its field, so they are reused only while they belong to the field as
// it is now (its point_cloud.ply's stamp: a refined field continued to more steps is scored again) and to
// the scoring asked for (`request`, recorded beside them; null for a plain row); else `score` makes them.
nlohmann::json scores_of_field(const std::string& field, const std::string& dir, const nlohmann::json& request,
                               const std::function<nlohmann::json()>& score) {
  const std::string metrics = (fs::path(dir) / "metrics.json").string();
  auto scores = reusable_scores(metrics);
  const std::string field_stamp = file_stamp((fs::path(field) / "point_cloud.ply").string());
  if (scores && scores->value("field_stamp", std::string()) == field_stamp &&
      (request.is_null() || scores->value("detail_request", nlohmann::json()) == request)) {
    return *scores;
  }
  nlohmann::json m = score();
  m["field_stamp"] = field_stamp;
  if (!request.is_null()) m["detail_request"] = request;
  write_json_file(metrics, m);
  return m;
}

}  // namespace

void ensure_latent_field(const LatentTrainOptions& job, const std::string& scene, const SceneResolution& resolution,
                         int train_views, const std::string& dir, const std::string& encoder) {
  LatentTrainOptions l = job;
  l.scene = scene;
  l.out = dir;
  l.scene_options.images_dir = resolution.images;
  l.scene_options.downscale = resolution.downscale;
  l.scene_options.train_views = train_views;
  l.encoder = encoder;
  const ArtefactLife life = field_life(
      dir, wanted_field_settings(scene, resolution, train_views, job, autoencoder_identity(job.autoencoder, encoder)));
  ensure_job_artefact(life, "field", &l, [&] {
    log_info("== latent field " + dir + (l.resume ? " (resuming)" : "") + ": " + std::to_string(l.iters) +
             " steps on the " + (encoder.empty() ? "stock" : "Stage I") + " encoder's latents of " + scene +
             " (" + (resolution.images.empty() ? "images" : resolution.images) + " downscaled " +
             std::to_string(resolution.downscale) + "x)");
    train_latent_field(l);
  });
}

// An RGB baseline: at latent resolution (factor 8) or full resolution (1), with or without Mip filters.
void ensure_rgb_field(const RgbTrainOptions& job, const std::string& scene, const SceneResolution& resolution,
                      const std::string& dir, const RgbBaseline& baseline) {
  const int factor = baseline.factor;
  const bool mip = baseline.mip;
  RgbTrainOptions b = job;
  b.scene = scene;
  b.scene_options.images_dir = resolution.images;
  b.scene_options.downscale = resolution.downscale;
  b.out = dir;
  b.factor = factor;
  b.mip = mip;
  b.task = std::string("train-rgb") + (factor == 1 ? "" : "/" + std::to_string(factor)) + (mip ? "-mip" : "");
  const ArtefactLife life =
      field_life(dir, wanted_field_settings(scene, resolution, job.scene_options.train_views, job, ""));
  ensure_job_artefact(life, "field", &b, [&] {
    log_info("== RGB field " + dir + (b.resume ? " (resuming)" : "") + ": " + std::to_string(b.iters) + " steps on " +
             scene + "'s views" + (factor > 1 ? " reduced " + std::to_string(factor) + "x" : "") +
             (mip ? ", with Mip-Splatting's filters" : ""));
    train_rgb_field(b);
  });
}

// The RGB rows are scored as lrf eval scores an RGB run.
nlohmann::json ensure_rgb_eval(const FieldScoring& scoring, const std::string& dir) {
  auto scores = reusable_scores((fs::path(dir) / "metrics.json").string());
  if (scores) return *scores;
  RgbEvalOptions e;
  e.lpips_weights = scoring.lpips_weights;
  return evaluate_rgb_run(dir, e);
}


// A field refined through `decoder` (refine_folder.h: reused, continued to more steps, resumed or made).
void refine_eval_field(const RefineOptions& job, const std::string& field, const std::string& decoder,
                       const std::string& dir) {
  RefineOptions r = job;
  r.run = field;
  r.out = dir;
  r.decoder = decoder;
  log_info("== refinement " + dir + ": up to " + refine_length_text(r) + " of " + field +
           " through its decoder (a finished one is reused)");
  ensure_refined_field(r, "the refined field", "use another output folder or remove " + dir, false);
}

bool encoder_finished(const EncoderFinetuneOptions& e) { return finished_as_wanted(encoder_life(e)); }

void ensure_encoder(const EncoderFinetuneOptions& stage1) {
  EncoderFinetuneOptions e = stage1;
  ensure_job_artefact(encoder_life(e), "Stage I encoder", &e, [&e] {
    log_info(std::string("== Stage I") + (e.resume ? " (resuming)" : "") + ": " + std::to_string(e.steps) +
             " steps of " + std::to_string(e.batch.pairs) + " view pairs in " + std::to_string(e.batch.crop) +
             "-pixel crops, on " + std::to_string(e.scenes.size()) + " training scene(s)");
    finetune_encoder(e);
  });
}

DecoderFinetuneOptions decoder_options(const DecoderFinetuneOptions& job, const std::vector<std::string>& fields,
                                       const std::string& encoder, const std::string& out) {
  DecoderFinetuneOptions d = job;
  d.fields = fields;
  d.encoder = encoder;
  d.out = out;
  return d;
}

bool decoder_finished(const DecoderFinetuneOptions& d) { return finished_as_wanted(decoder_life(d)); }

void ensure_decoder(const DecoderFinetuneOptions& stage3) {
  DecoderFinetuneOptions d = stage3;
  ensure_job_artefact(decoder_life(d), "Stage III decoder", &d, [&d] {
    log_info("== Stage III " + d.out + (d.resume ? " (resuming)" : "") + ": " + std::to_string(d.steps) +
             " steps on " + std::to_string(d.fields.size()) + " field(s)");
    finetune_decoder(d);
  });
}

nlohmann::json ensure_latent_eval(const FieldScoring& scoring, const std::string& field, const std::string& decoder,
                                  const std::string& dir) {
  return scores_of_field(field, dir, nullptr, [&] {
    LatentEvalOptions e;
    e.decoder = decoder;
    e.lpips_weights = scoring.lpips_weights;
    e.output_dir = dir;
    return evaluate_latent_run(field, e);
  });
}

nlohmann::json ensure_detail_eval(const detail::DetailEvalOptions& scoring, const std::string& field,
                                  const std::string& dir, const nlohmann::json& field_scores) {
  return scores_of_field(field, dir, detail::detail_options_json(scoring.detail), [&] {
    detail::DetailEvalOptions e = scoring;
    e.decoder.clear();  // the refined field's own
    return detail::evaluate_with_detail(field, dir, e, &field_scores);
  });
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

}  // namespace lrf
