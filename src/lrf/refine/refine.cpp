#include "lrf/refine/refine.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <sstream>

#include <torch/torch.h>

#include "lrf/autoencoder/image_tensor.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/paths.h"
#include "lrf/core/progress.h"
#include "lrf/core/resources.h"
#include "lrf/core/run_info.h"
#include "lrf/core/seed_stream.h"
#include "lrf/core/training_steps.h"
#include "lrf/latent/latent_cache.h"
#include "lrf/latent/latent_field.h"
#include "lrf/latent/latent_run.h"
#include "lrf/latent/latent_scoring.h"
#include "lrf/optim/param_adam.h"
#include "lrf/refine/decoded_loss.h"
#include "lrf/scene/run_scene_location.h"
#include "lrf/scene/scene_outputs.h"
#include "lrf/splat/render_field.h"
#include "lrf/splat/run/train_run.h"
#include "lrf/splat/train/loss.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

void check_options(const RefineOptions& o) {
  if (o.run.empty() || o.out.empty()) fail("refine: give the latent run to refine and an output folder (-o)");
  if (canonical_path(o.run) == canonical_path(o.out)) {
    fail(o.out, "refine writes a new run: choose another output folder");
  }
  if (o.steps < 0) fail("refine: --steps must be 0 (" + std::to_string(kRefineStepsPerView) + " per training view) or positive");
  if (o.steps > 0) check_training_steps(o.steps);
  if (o.crop < 0 || o.crop % 8) fail("refine: --crop must be 0 (whole views) or a positive multiple of 8");
  if (!(o.lr_scale > 0) || !(o.position_lr > 0) || !(o.lr_final > 0 && o.lr_final <= 1))
    fail("refine: learning rates must be positive, and --lr-final in (0, 1]");
  if (!(o.lr_decay_start >= 0 && o.lr_decay_start < 1)) fail("refine: --lr-decay-start must be in [0, 1)");
  if (!(o.geometry_lr_scale >= 0)) fail("refine: --geometry-lr-scale must be 0 (frozen geometry) or positive");
  if (!(o.decoder_lr >= 0)) fail("refine: --decoder-lr must be 0 (frozen decoder) or positive");
  if (o.decoder_scale < 0 || (o.decoder_scale & (o.decoder_scale - 1)) != 0)
    fail("refine: --decoder-scale must be 0 (every layer) or a power of two (1, 2, 4, 8)");
  if (!(o.lambda_ssim >= 0 && o.lambda_ssim <= 1)) fail("refine: --lambda-ssim must be in [0, 1]");
  if (!(o.lambda_latent >= 0)) fail("refine: --lambda-latent must be 0 or positive");
  if (o.jitter < 0 || o.jitter > 7) fail("refine: --jitter must be in 0..7 pixels (a latent cell is 8)");
  if (o.jitter > 0 && o.lambda_latent > 0)
    fail("refine: --lambda-latent needs --jitter 0 (the encoded views it holds the field to are of unshifted "
         "cameras)");
  if (o.densify_until < 0 || o.densify_interval < 1 || !(o.densify_grad > 0))
    fail("refine: --densify-until must be 0 (no densification) or a step, --densify-interval at least 1 and "
         "--densify-grad positive");
}

// The step's camera shift in image pixels (x, y), from a stream of its own, so that windows and view order
// are those of a run without jitter.
std::pair<int, int> jitter_of_step(const RefineOptions& o, int64_t step) {
  if (o.jitter <= 0) return {0, 0};
  std::mt19937_64 rng(stream_seed(o.seed, SeedStream::refine_jitter, static_cast<uint64_t>(step)));
  std::uniform_int_distribution<int> pixels(0, o.jitter);
  const int dx = pixels(rng);
  return {dx, pixels(rng)};
}

// The wall time of what the refined field's source took: encoding the training views and Stage II.
double source_seconds(const nlohmann::json& source_config) {
  const nlohmann::json result = source_config.value("result", nlohmann::json::object());
  return result.value("seconds", 0.0) + result.value("encode_seconds", 0.0);
}

// `o` with its length resolved from the source run's recorded configuration `c` (read from `path`).
RefineOptions with_refine_steps_of(RefineOptions o, const nlohmann::json& c, const std::string& path) {
  if (o.steps != 0) return o;
  const int64_t views = c.value("train_views", int64_t(0));
  if (views < 1) fail(path, "records no training views (\"train_views\"), so the default --steps is unknown: give --steps");
  o.steps = refine_steps(o, views);
  return o;
}

}  // namespace

int64_t refine_steps(const RefineOptions& o, int64_t train_views) {
  if (o.steps > 0) return o.steps;
  return std::max<int64_t>(100, (kRefineStepsPerView * train_views + 50) / 100 * 100);
}

RefineOptions with_refine_steps(RefineOptions o) {
  if (o.steps != 0) return o;
  const std::string config = (fs::path(o.run) / "config.json").string();
  if (!fs::exists(config)) fail(config, "not found: refine needs a finished latent field");
  return with_refine_steps_of(o, read_json_file(config), config);
}

std::string refine_length_text(const RefineOptions& o) {
  return o.steps > 0 ? std::to_string(o.steps) + " steps"
                     : std::to_string(kRefineStepsPerView) + " steps per training view";
}

std::string refine_description(const RefineOptions& o) {
  std::ostringstream s;
  s << refine_length_text(o);
  if (o.lr_scale != 1) s << " at Stage II's rates x" << o.lr_scale;
  if (o.crop > 0) s << " on " << o.crop << " px windows";
  if (o.decoder_lr > 0) {
    s << ", decoder adapted at Adam rate " << o.decoder_lr;
    if (o.decoder_scale > 0) s << " up to " << o.decoder_scale << "x the latent resolution";
  }
  else s << ", frozen decoder";
  if (o.geometry_lr_scale == 0) s << ", geometry frozen";
  else if (o.geometry_lr_scale != 1) s << ", geometry rates x" << o.geometry_lr_scale;
  if (o.densify_until > 0) s << ", densified until step " << o.densify_until;
  if (o.lambda_latent > 0) s << ", latent anchor weight " << o.lambda_latent;
  if (o.jitter > 0) s << ", cameras jittered by up to " << o.jitter << " px";
  return s.str();
}

nlohmann::json refine_options_json(const RefineOptions& o) {
  return {{"run", o.run},         {"out", o.out},           {"decoder", o.decoder},
          {"steps", o.steps},     {"crop", o.crop},         {"lr_scale", o.lr_scale},
          {"position_lr", o.position_lr}, {"geometry_lr_scale", o.geometry_lr_scale},
          {"lr_final", o.lr_final}, {"lr_decay_start", o.lr_decay_start}, {"lambda_ssim", o.lambda_ssim},
          {"decoder_lr", o.decoder_lr}, {"decoder_scale", o.decoder_scale}, {"lambda_latent", o.lambda_latent},
          {"jitter", o.jitter},
          {"densify_until", o.densify_until}, {"densify_interval", o.densify_interval},
          {"densify_grad", o.densify_grad}, {"seed", o.seed},
          {"checkpoint_every", o.checkpoint_every}, {"score_every", o.score_every}, {"resume", o.resume},
          {"force", o.force}};
}

nlohmann::json refine_resume_key(const RefineOptions& o) {
  nlohmann::json j = refine_options_json(o);
  // A decaying schedule depends on the run's length: then --steps may not change on resume.
  for (const char* k : {"checkpoint_every", "score_every", "resume", "force", "out"}) j.erase(k);
  if (o.lr_final == 1) j.erase("steps");
  // Runs refined before the option existed decayed from the first step: the same key.
  if (o.lr_decay_start == 0) j.erase("lr_decay_start");
  j["run"] = canonical_path(o.run);
  return j;
}

namespace {

// The source field, opened and checked, and the options with its step count; a --resume must continue a
// run refined with the same options.
RefineOptions checked_source(const RefineOptions& options, LatentRun* src) {
  check_options(options);
  *src = open_latent_run(options.run);
  refuse_output_in_scene(options.out, src->scene);
  const RefineOptions o = with_refine_steps_of(options, src->config, (fs::path(options.run) / "config.json").string());
  if (src->scene.train_indices.empty()) fail(o.run, "the scene has no training views");
  if (src->lift.defined())
    fail(o.run, "a feature field (feature-gs) cannot be refined: refinement moves latent features, and this field's "
                "features are lifted to latents by its own 1x1 convolution");
  const std::string config_path = (fs::path(o.out) / "config.json").string();
  if (o.resume) {
    if (!fs::exists(config_path)) fail(config_path, "--resume: not found");
    const nlohmann::json recorded = read_json_file(config_path);
    if (!recorded.contains("refine") || recorded["refine"].value("resume_key", nlohmann::json()) != refine_resume_key(o)) {
      fail(config_path, "--resume: this run was refined with other options (resume with the same run, decoder, "
                        "crop, learning rates, SSIM weight and seed)");
    }
  }
  return o;
}

// The trainer's schedule and rates for a refinement. The SH degree stays as Stage II left it, and there is
// no opacity reset (it would undo the fit the refinement starts from); the field grows only if asked to.
splat::TrainerOptions refine_trainer_options(const RefineOptions& o, const LatentRun& src) {
  splat::TrainerOptions to;
  to.iterations = o.steps;
  to.sh_degree = src.render.sh_degree;
  to.seed = o.seed;
  to.background = src.render.background;
  to.schedule.from = o.densify_until > 0 ? o.densify_interval : 0;
  to.schedule.until = o.densify_until;
  to.schedule.interval = o.densify_interval;
  to.schedule.opacity_reset_every = std::numeric_limits<int64_t>::max();
  to.schedule.sh_degree_every = 1;
  to.densify.grad_threshold = o.densify_grad;
  splat::LearningRates lr;
  lr.position_init = o.position_lr * o.geometry_lr_scale;
  lr.position_final = o.position_lr * o.geometry_lr_scale * o.lr_final;
  lr.others_final_factor = o.lr_final;
  lr.decay_start = o.lr_decay_start;
  lr.scales *= o.lr_scale * o.geometry_lr_scale;
  lr.rotations *= o.lr_scale * o.geometry_lr_scale;
  lr.opacity *= o.lr_scale * o.geometry_lr_scale;
  lr.sh_dc *= o.lr_scale;
  lr.sh_rest *= o.lr_scale;
  to.lr = lr;
  return to;
}

// The encoded training views, normalised with the field's range, for --lambda-latent (none without it).
std::vector<torch::Tensor> latent_anchors(const RefineOptions& o, const LatentRun& src, Autoencoder& ae) {
  std::vector<torch::Tensor> anchors;
  if (o.lambda_latent <= 0) return anchors;
  auto encoded = encode_views_cached(src.scene, src.scene.train_indices, ae,
                                     autoencoder_identity(src.autoencoder, src.encoder),
                                     o.cache_dir.empty() ? default_cache_dir() : o.cache_dir);
  for (const auto& z : encoded.latents) anchors.push_back(src.range.normalize(z).contiguous());
  return anchors;
}

// The refinement's objective: the rendered latent decoded (in a window with the decoder's context, or
// whole) and compared with the training photograph, its backward run down to the latent here.
splat::Objective decoded_objective(const RefineOptions& o, const LatentRun& src, Autoencoder& ae,
                                   const std::vector<torch::Tensor>& images, const std::vector<torch::Tensor>& anchors,
                                   int reach) {
  return [&o, &src, &ae, &images, &anchors, reach](const torch::Tensor& rendered, int view, int64_t step) {
    const torch::Tensor& image = images[static_cast<size_t>(view)];
    std::mt19937_64 rng(stream_seed(o.seed, SeedStream::refine_windows, static_cast<uint64_t>(step)));
    const DecodeWindow win = plan_window(rendered.size(1), rendered.size(2), o.crop / 8, reach, rng);
    const auto [dx, dy] = jitter_of_step(o, step);
    // The decoder's backward runs here, down to the rendered latent, so that the step's profile tells the
    // decoder's share from the field's; the trainer carries the latent's gradient on into the Gaussians.
    const torch::Tensor latent = rendered.detach().requires_grad_(true);
    DecodedLoss d = decoded_loss(ae, src.range, latent, image, win, o.lambda_ssim, dx, dy);
    torch::Tensor loss = d.loss;
    if (o.lambda_latent > 0) loss = loss + o.lambda_latent * (latent - anchors[static_cast<size_t>(view)]).abs().mean();
    splat::ObjectiveValue value;
    value.psnr = splat::psnr(d.decoded.detach(), d.target);
    const auto t0 = std::chrono::steady_clock::now();
    loss.backward();
    value.backward_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    value.loss = loss.detach();
    value.rendered_grad = latent.grad();
    return value;
  };
}

// The refined run's config.json before training: the source's, with the decoder it is decoded by (an
// adapted one: this run's own file, identified once final) and the refinement's options.
nlohmann::json refine_config(const RefineOptions& o, const LatentRun& src, const std::string& decoder,
                             const std::string& adapted, int reach) {
  nlohmann::json config = src.config;
  config.update(scene_location_record(src.scene.root, o.out));  // relative to this run's folder
  config.erase("result");
  config["decoder"] = decoder;
  config["decoder_identity"] = decoder.empty() ? std::string() : weights_file_identity(decoder);
  if (o.decoder_lr > 0) {
    config["decoder"] = adapted;
    config["decoder_identity"] = "";  // set when the adapted decoder is final
    config["refine_source_decoder"] = decoder;
  }
  config["refine"] = run_record(refine_options_json(o));
  config["refine"]["refined_from"] = canonical_path(o.run);
  config["refine"]["resume_key"] = refine_resume_key(o);
  config["refine"]["decoder_local_reach"] = reach;
  return config;
}

// --score-every: the test views scored as the field refines, one row of curve.csv each, against the wall
// time of the whole row (the source's encoding and fit, then this refinement).
void score_while_refining(const RefineOptions& o, const LatentRun& src, Autoencoder& ae, splat::Trainer& trainer,
                          splat::RunOptions* ro) {
  if (src.scene.test_indices.empty()) fail(o.run, "--score-every: the scene has no test views to score");
  const double before = source_seconds(src.config);
  ro->score_every = o.score_every;
  ro->score_header = "step,seconds,refine_seconds,psnr,ssim,ms_ssim,flip,gaussians";
  ro->score = [&src, &ae, &trainer, before](int64_t, double refine_seconds) {
    LatentScoring scoring;
    scoring.scene = &src.scene;
    scoring.range = &src.range;
    scoring.autoencoder = &ae;
    scoring.autoencoder_identity = autoencoder_identity(src.autoencoder, src.encoder);
    const splat::Gaussians field = trainer.export_gaussians();
    scoring.render = [&](int view) {
      return render_field(field, latent_camera(src.scene.views[static_cast<size_t>(view)].camera), src.render).image;
    };
    const nlohmann::json m = score_latent_test_views(scoring);
    std::ostringstream row;
    row << before + refine_seconds << "," << refine_seconds;
    // A score the images are too small for (MS-SSIM below its five scales) is null: an empty cell.
    for (const char* k : {"psnr", "ssim", "ms_ssim", "flip"}) {
      row << ",";
      if (m.contains(k) && m[k].is_number()) row << m[k].get<double>();
    }
    row << "," << field.size();
    return row.str();
  };
}

// config.json's result: the refinement's, with the source's fit and encoding, so that the row's time is
// everything it took.
nlohmann::json refine_result(const LatentRun& src, const splat::RunSummary& summary) {
  const nlohmann::json source_result = src.config.value("result", nlohmann::json::object());
  const double stage2_seconds = source_result.value("seconds", 0.0);
  return {{"steps", summary.steps},
          {"gaussians", summary.gaussians},
          {"refine_seconds", summary.seconds},
          {"stage2_seconds", stage2_seconds},
          {"seconds", stage2_seconds + summary.seconds},
          {"encode_seconds", source_result.value("encode_seconds", 0.0)},
          {"final_loss", summary.last_loss},
          {"final_psnr", summary.last_psnr},
          {"peak_memory_mb", std::max(peak_memory_mb(), source_result.value("peak_memory_mb", 0.0))}};
}

}  // namespace

RefineResult refine_latent_field(const RefineOptions& options) {
  using namespace lrf::splat;
  const Stopwatch preparing;
  LatentRun src;
  const RefineOptions o = checked_source(options, &src);
  const std::string config_path = (fs::path(o.out) / "config.json").string();
  const auto lock = prepare_output_dir(o.out, o.force, o.resume);

  const std::string decoder = o.decoder.empty() ? src.decoder : o.decoder;
  auto ae = load_autoencoder(src.autoencoder, src.encoder, decoder);
  ae->set_encoder_trainable(false);
  ae->set_decoder_trainable(o.decoder_lr > 0, o.decoder_scale);
  // An adapted decoder is this run's own, written beside the field at every checkpoint.
  const std::string adapted = fs::absolute(fs::path(o.out) / "decoder.safetensors").lexically_normal().string();
  const std::string adapted_checkpoint = (fs::path(o.out) / "decoder.checkpoint.safetensors").string();
  std::unique_ptr<ParamAdam> decoder_adam;
  if (o.decoder_lr > 0)
    decoder_adam = std::make_unique<ParamAdam>(ae->decoder_parameters(o.decoder_scale), AdamOptions{o.decoder_lr});
  const int reach = ae->decode_local_reach();

  // Training views: latent cameras, with the full-resolution images as what the objective compares with.
  std::vector<TrainView> views;
  std::vector<torch::Tensor> images;  // shared with the views' targets (which the trainer takes over)
  for (int i : src.scene.train_indices) {
    const View& v = src.scene.views[static_cast<size_t>(i)];
    images.push_back(image_to_batch(src.scene.load_image(i))[0].contiguous());
    views.push_back({v.name, latent_camera(v.camera), images.back()});
  }
  const std::vector<torch::Tensor> anchors = latent_anchors(o, src, *ae);
  const auto& c0 = views.front().camera;
  log_info("refining " + o.run + " (" + std::to_string(src.field.size()) + " Gaussians) through " +
           (decoder.empty() ? ae->description() + "'s decoder" : decoder) + " on " + std::to_string(views.size()) +
           " training views at " + std::to_string(8 * c0.width) + "x" + std::to_string(8 * c0.height) +
           (o.crop > 0 ? ", windows of " + std::to_string(o.crop) + " px" : ", whole views") +
           (reach >= 0 ? " (decoder context " + std::to_string(reach) + " latent cells)" : " (decoded whole)"));

  TrainerOptions to = refine_trainer_options(o, src);
  to.objective = decoded_objective(o, src, *ae, images, anchors, reach);
  if (o.jitter > 0) {
    to.camera_of_step = [&](const Camera& camera, int, int64_t step) {
      const auto [dx, dy] = jitter_of_step(o, step);
      return shifted_latent_camera(camera, dx, dy);
    };
  }
  if (decoder_adam) {
    to.after_backward = [&, lr = to.lr](int64_t step) {
      // The decoder's rate follows the field's (--lr-final), so that a decaying run ends with a decoder
      // that no longer follows the last views it saw.
      decoder_adam->set_lr(o.decoder_lr * lr.others_factor(step, o.steps));
      decoder_adam->step();
      decoder_adam->zero_grad();
    };
  }
  nlohmann::json config = refine_config(o, src, decoder, adapted, reach);
  write_json_file(config_path, config);

  Trainer trainer(std::move(views), src.field, src.config.value("extent", src.scene.camera_extent()), to);
  RunOptions ro(o);
  ro.log_every = 10;
  ro.task = "refine";
  if (decoder_adam) {
    ro.save_extra = [&] {
      decoder_adam->save(adapted_checkpoint, {{"lrf_kind", "refine-decoder"}, {"lrf_resume_key", refine_resume_key(o).dump()}});
      ae->save_decoder(adapted);
    };
    ro.load_extra = [&] {
      const auto meta = decoder_adam->load(adapted_checkpoint);
      if (meta.count("lrf_resume_key") == 0 || meta.at("lrf_resume_key") != refine_resume_key(o).dump())
        fail(adapted_checkpoint, "was written by another refinement (other options)");
    };
  }
  if (o.score_every > 0) score_while_refining(o, src, *ae, trainer, &ro);
  ro.prepared_seconds = preparing.seconds();
  auto summary = run_training(trainer, ro);
  if (decoder_adam) config["decoder_identity"] = weights_file_identity(adapted);
  config["result"] = refine_result(src, summary);
  write_json_file(config_path, config);
  log_info("wrote " + o.out + "/point_cloud.ply: refined " + std::to_string(summary.steps) + " steps in " +
           Progress::format_duration(summary.seconds));
  return {summary.steps, summary.gaussians, summary.seconds, summary.last_loss, summary.last_psnr};
}

}  // namespace lrf
