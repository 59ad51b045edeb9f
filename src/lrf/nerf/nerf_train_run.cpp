#include "lrf/nerf/nerf_train_run.h"

// lrf train --space latent-nerf: the training run on disk (see nerf_run.h).
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <sstream>

#include <torch/torch.h>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/progress.h"
#include "lrf/core/resources.h"
#include "lrf/core/run_info.h"
#include "lrf/core/run_loop.h"
#include "lrf/core/train_log.h"
#include "lrf/core/training_steps.h"
#include "lrf/latent/encoded_scene.h"
#include "lrf/latent/latent_field.h"
#include "lrf/nerf/nerf_run.h"
#include "lrf/nerf/nerf_trainer.h"
#include "lrf/splat/run/field_kind.h"
#include "lrf/splat/run/run_folder.h"
#include "lrf/splat/run/train_run.h"

namespace fs = std::filesystem;

namespace lrf::nerf {
namespace {

constexpr const char* kLogHeader = "step,loss,psnr,elapsed_s,sampling_ms,forward_ms,backward_ms,adam_ms";
constexpr int kElapsedColumn = 3;
constexpr int64_t kLogEvery = 10;

nlohmann::json options_json(const LatentNerfOptions& o) {
  return {{"scene", o.scene},           {"out", o.out},
          {"images", o.scene_options.images_dir},         {"autoencoder", o.autoencoder},
          {"encoder", o.encoder},       {"downscale", o.scene_options.downscale},
          {"test_every", o.scene_options.test_every}, {"train_views", o.scene_options.train_views},
          {"iters", o.iters},           {"checkpoint_every", o.checkpoint_every},
          {"rays", o.rays},             {"samples", o.samples},
          {"log2_table", o.log2_table}, {"seed", o.seed},
          {"resume", o.resume},         {"force", o.force},
          {"init_points", o.init_points.mode}, {"preset", o.preset}};
}

// Refuses an existing folder unless --force or --resume (see splat::prepare_output_dir); --force removes a
// stale checkpoint so the run starts afresh.
splat::OutputFolder prepare_nerf_output(const LatentNerfOptions& o) {
  const std::string checkpoint = nerf_checkpoint_path(o.out);
  if (o.resume && !fs::exists(checkpoint)) splat::fail_no_checkpoint(checkpoint, o.out);
  splat::OutputFolder lock = splat::prepare_output_dir(o.out, o.force || o.resume, false);
  if (o.force && !o.resume) {
    std::error_code ec;
    fs::remove(checkpoint, ec);
  }
  return lock;
}

void check_options(const LatentNerfOptions& o) {
  check_training_steps(o.iters);
  if (o.rays < 1 || o.rays > (1 << 20)) fail_usage("--rays must be between 1 and 1048576");
  if (o.samples < 2 || o.samples > 1024) fail_usage("--samples must be between 2 and 1024");
  if (o.log2_table < 10 || o.log2_table > 24) fail_usage("--hash-log2 must be between 10 and 24");
  if (o.checkpoint_every < 0) fail_usage("--checkpoint-every must be 0 (only at the end) or positive");
  require_latent_scene_options(o.scene_options, "latent-nerf");
}

}  // namespace


LatentNerfResult train_latent_nerf(const LatentNerfOptions& o) {
  const Stopwatch preparing;
  check_options(o);
  const auto lock = prepare_nerf_output(o);
  reset_peak_memory();  // this job's own peak, when another ran before it in this process (lrf compare)

  EncodedScene encoded = load_encoded_scene({o.scene, o.scene_options, o.autoencoder, o.encoder, o.cache_dir});
  const Scene& scene = encoded.scene;
  auto& ae = encoded.autoencoder;
  const LatentRange range = compute_latent_range(encoded.latents);
  std::vector<Camera> image_cameras, latent_cameras;
  std::vector<at::Tensor> targets;
  for (size_t k = 0; k < scene.train_indices.size(); ++k) {
    const Camera& cam = scene.views[static_cast<size_t>(scene.train_indices[k])].camera;
    image_cameras.push_back(cam);
    latent_cameras.push_back(latent_camera(cam));
    targets.push_back(range.normalize(encoded.latents[k]));
  }

  const std::string config_path = (fs::path(o.out) / "config.json").string();
  NerfSpec spec;
  nlohmann::json init_points_record;
  if (o.resume) {
    // The field's layout and bounds as the run recorded them: the checkpoint must fit them exactly.
    const nlohmann::json before = read_json_file(config_path);
    if (!before.contains("nerf")) fail(config_path, "cannot resume: no \"nerf\" spec recorded");
    spec = NerfSpec::from_json(before["nerf"], config_path);
    init_points_record = before.value("init_points", nlohmann::json());
  } else {
    // The scene's extent from the points the Gaussian fields start from (SfM, triangulated or a file).
    InitPointsOptions points_options = o.init_points;
    if (points_options.cache_dir.empty()) points_options.cache_dir = o.cache_dir;
    const InitialPoints initial = choose_initial_points(scene, points_options);
    std::vector<Eigen::Vector3d> points;
    for (const auto& p : initial.points) points.push_back(p.xyz);
    spec.grid.log2_table = o.log2_table;
    spec.channels = ae->latent_channels();
    spec.coarse_samples = o.samples;
    spec.fine_samples = o.samples;
    spec.bounds = bounds_from_points(image_cameras, points, scene.camera_mean(), scene.camera_extent());
    spec.background.assign(static_cast<size_t>(spec.channels), 0.0f);  // as the latent field: 0 in normalised space
    init_points_record = initial.record;
    log_info("scene bounds from " + initial.description + ": depth " + std::to_string(spec.bounds.near) + " to " +
             std::to_string(spec.bounds.far));
  }
  if (spec.channels != ae->latent_channels())
    fail(config_path, "the recorded field has " + std::to_string(spec.channels) + " channels, the autoencoder " +
                          std::to_string(ae->latent_channels()));

  NerfTrainOptions to;
  to.iterations = o.iters;
  to.rays_per_step = o.rays;
  to.seed = o.seed;
  NerfField field = NerfField::create(spec, o.seed);

  auto config = run_record(options_json(o));
  config.update(splat::scene_config(o.scene, encoded.options, scene, o.out));
  config["space"] = field_kind_name(FieldKind::latent_nerf);
  config["background"] = spec.background;
  config["autoencoder"] = o.autoencoder;
  config["encoder"] = o.encoder;
  config["autoencoder_identity"] = encoded.autoencoder_identity;
  config["latent_channels"] = spec.channels;
  config["latent_range"] = range.to_json();
  config["nerf"] = spec.to_json();
  config["nerf_training"] = {{"iterations", to.iterations}, {"rays_per_step", to.rays_per_step},
                             {"lr", to.lr},                 {"lr_final", to.lr_final},
                             {"loss", "mse"},               {"parameters", field.parameter_count()}};
  config["init_points"] = init_points_record;
  write_json_file(config_path, config);

  NerfTrainer trainer(std::move(field), training_rays(latent_cameras, targets), to);
  const std::string checkpoint = nerf_checkpoint_path(o.out), field_path = nerf_field_path(o.out);
  TrainLog log((fs::path(o.out) / "train_log.csv").string(), kLogHeader, kElapsedColumn);
  double elapsed_before = 0;
  if (o.resume) {
    trainer.load_checkpoint(checkpoint);
    elapsed_before = log.resume(trainer.steps_done());
    log_info("resuming " + o.out + " at step " + std::to_string(trainer.steps_done()));
  }
  log_info("latent NeRF: " + std::to_string(trainer.field().parameter_count()) + " parameters, " +
           std::to_string(o.rays) + " rays x " + std::to_string(spec.samples()) + " samples per step");

  Progress progress("train-latent-nerf", o.iters, 2.0, trainer.steps_done());
  double loss_sum = 0, psnr_sum = 0, time_sum[4] = {0, 0, 0, 0}, last_loss = 0;
  int64_t count = 0;
  RunLoop loop;
  loop.total_steps = o.iters;
  loop.first_step = trainer.steps_done();
  loop.checkpoint_every = o.checkpoint_every;
  loop.checkpoint = checkpoint;
  loop.progress = &progress;
  loop.expected_time_note = "training only; scoring adds its own time";
  loop.prepared_seconds = preparing.seconds();
  // The log first: killed before the checkpoint is written, a resumed run drops the log's rows past the
  // previous checkpoint; the other way round it would lose rows.
  loop.save = [&] {
    log.write();
    trainer.save_checkpoint(checkpoint);
    trainer.field().save(field_path, {{"step", std::to_string(trainer.steps_done())}});
  };
  loop.step = [&] {
    const NerfStepResult r = trainer.step();
    loss_sum += r.loss;
    psnr_sum += r.psnr;
    last_loss = r.loss;
    const double times[4] = {r.timings.sampling, r.timings.forward, r.timings.backward, r.optimizer_seconds};
    for (int k = 0; k < 4; ++k) time_sum[k] += times[k];
    ++count;
    if (r.step % kLogEvery == 0 || trainer.done()) {
      std::ostringstream row;
      row << r.step << "," << std::setprecision(6) << loss_sum / double(count) << "," << std::setprecision(4)
          << psnr_sum / double(count) << "," << std::setprecision(6) << elapsed_before + progress.elapsed_seconds()
          << std::setprecision(4);
      for (double t : time_sum) row << "," << 1000.0 * t / double(count);
      log.add(row.str());
      loss_sum = psnr_sum = 0;
      for (double& t : time_sum) t = 0;
      count = 0;
    }
    return LoopStep{r.step, {{"loss", r.loss}, {"psnr", r.psnr}}};
  };
  run_loop(loop);
  progress.finish({{"loss", last_loss}});
  LatentNerfResult result;
  result.steps = trainer.steps_done();
  result.parameters = trainer.field().parameter_count();
  result.seconds = elapsed_before + progress.elapsed_seconds();
  result.encode_seconds = encoded.encode_seconds;
  result.final_loss = last_loss;
  config["result"] = {{"steps", result.steps},          {"seconds", result.seconds},
                      {"encode_seconds", encoded.encode_seconds}, {"final_loss", last_loss},
                      {"parameters", result.parameters},  {"peak_memory_mb", peak_memory_mb()}};
  write_json_file(config_path, config);
  log_info("wrote " + field_path + ": " + std::to_string(result.parameters) + " parameters after " +
           std::to_string(result.steps) + " steps in " + Progress::format_duration(result.seconds));
  return result;
}

LatentNerfOptions recorded_nerf_options(const std::string& out) {
  const std::string path = (fs::path(out) / "config.json").string();
  if (!fs::exists(path)) fail(path, "not found: nothing to resume in " + out);
  const nlohmann::json config = read_json_file(path);
  if (field_kind_of_config(config, path) != FieldKind::latent_nerf) fail(path, "not a latent NeRF run");
  LatentNerfOptions o;
  try {
    const auto& j = config.at("options");
    o.scene = j.at("scene").get<std::string>();
    o.out = out;
    o.scene_options.images_dir = j.at("images").get<std::string>();
    o.autoencoder = j.at("autoencoder").get<std::string>();
    o.encoder = j.at("encoder").get<std::string>();
    o.scene_options.downscale = j.at("downscale").get<int>();
    o.scene_options.test_every = j.at("test_every").get<int>();
    o.scene_options.train_views = j.at("train_views").get<int>();
    o.iters = j.at("iters").get<int64_t>();
    o.checkpoint_every = j.at("checkpoint_every").get<int64_t>();
    o.rays = j.at("rays").get<int>();
    o.samples = j.at("samples").get<int>();
    o.log2_table = j.at("log2_table").get<int>();
    o.seed = j.at("seed").get<uint64_t>();
    o.init_points.mode = j.at("init_points").get<std::string>();
    o.preset = j.value("preset", std::string("default"));  // runs from before presets had none
  } catch (const nlohmann::json::exception& e) {
    fail(path, std::string("cannot resume: missing or bad options: ") + e.what());
  }
  return o;
}

}  // namespace lrf::nerf
