// lrf train: fit a Gaussian field to a scene. `--space rgb` fits colours; Stage II adds `--space latent`;
// `--space latent-nerf` fits a NeRF to the same latents (the paper's Latent-NeRF* baseline).
#include <filesystem>
#include <memory>

#include "autoencoder_option.h"
#include "command.h"
#include "next_steps.h"
#include "init_points_options.h"
#include "preset_option.h"
#include "scene_options.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/paths.h"
#include "lrf/core/run_info.h"
#include "lrf/latent/latent_run.h"
#include "lrf/nerf/nerf_run.h"
#include "lrf/run/field_kind.h"
#include "lrf/scene/run_scene_location.h"
#include "lrf/scene/scene.h"
#include "lrf/rgb/rgb_train_run.h"
#include "lrf/splat/run/run_config.h"
#include "lrf/splat/train/densify.h"

namespace {

struct TrainOptions {
  std::string scene;
  std::string space = "rgb";
  std::string out;
  lrf::SceneOptions scene_options;
  int64_t iters = 30000;
  bool iters_set = false;
  int sh_degree = 3;
  bool sh_degree_set = false;
  bool mip = false;
  uint64_t seed = 0;
  int64_t max_gaussians = 0;
  double densify_grad = lrf::splat::DensifyOptions{}.grad_threshold;
  bool inria_rates = false;  // latent: no faster means and SH in runs under 7000 steps
  bool resume = false;
  bool force = false;
  int64_t checkpoint_every = 1000;
  bool sparse_adam = false;
  bool white_background = false;
  int coarse_factor = 1;       // rgb: > 1 trains the first steps on reduced views
  int64_t coarse_until = -1;   // the coarse phase's last step; -1: where densification ends
  // --space latent (Stage II)
  std::string autoencoder = "taef2";
  std::string encoder;
  std::string init = "latents";
  double rgb_guide = 0;
  int feature_dim = 0;  // > 0: a feature field (the feature-gs baseline)
  std::string cache_dir;
  lrf::InitPointsOptions init_points;
  // --space latent-nerf
  int rays = 1024, samples = 32, hash_log2 = 17;
  bool nerf_option_set = false;  // one of the three above was given
  std::string preset = lrf::kDefaultPreset;  // recorded, so that --resume can say when another is asked for
};

int run_train_latent(const TrainOptions& o, const lrf::InitPointsOptions& points) {
  lrf::LatentTrainOptions l;
  l.scene = o.scene;
  l.out = o.out;
  l.autoencoder = o.autoencoder;
  l.encoder = o.encoder;
  l.init = o.init;
  l.rgb_guide = o.rgb_guide;
  l.cache_dir = o.cache_dir;
  l.scene_options = o.scene_options;
  // A negative count is compare's "half the latent channels", met here only in a run being resumed.
  if (o.feature_dim < 0 && !o.resume) lrf::fail_usage("--feature-dim must be 0 (a latent field) or a feature count");
  l.feature_dim = o.feature_dim;
  // --test-list and --format are refused by the job itself (require_latent_scene_options).
  if (o.scene_options.crop_to_multiple_of_8)
    lrf::fail_usage("--crop8 does not apply to --space latent: latent views are always cropped to multiples of 8");
  l.sh_degree = o.sh_degree_set ? o.sh_degree : lrf::kDefaultLatentShDegree;
  l.iters = o.iters;
  l.max_gaussians = o.max_gaussians;
  l.densify_grad = o.densify_grad;
  l.short_run_rates = !o.inria_rates;
  l.checkpoint_every = o.checkpoint_every;
  l.seed = o.seed;
  l.resume = o.resume;
  l.force = o.force;
  l.sparse_adam = o.sparse_adam;
  l.init_points = points;
  l.preset = o.preset;
  if (o.mip) lrf::fail_usage("--mip applies to RGB fields (the paper's Mip-Splatting/8 baseline)");
  lrf::train_latent_field(l);
  return 0;
}

int run_train_nerf(const TrainOptions& o, const lrf::InitPointsOptions& points) {
  if (o.mip || o.sh_degree_set || o.max_gaussians || o.sparse_adam || o.white_background || o.init != "latents" ||
      o.densify_grad != lrf::splat::DensifyOptions{}.grad_threshold)
    lrf::fail_usage("--mip, --sh-degree, --max-gaussians, --densify-grad, --sparse-adam, --white-background and --init apply to Gaussian "
              "fields, not to --space latent-nerf");
  if (o.scene_options.crop_to_multiple_of_8)
    lrf::fail_usage("--crop8 does not apply to --space latent-nerf: latent views are always cropped to multiples of 8");
  lrf::nerf::LatentNerfOptions n;
  n.scene = o.scene;
  n.out = o.out;
  n.autoencoder = o.autoencoder;
  n.encoder = o.encoder;
  n.cache_dir = o.cache_dir;
  n.scene_options = o.scene_options;
  n.iters = o.iters_set ? o.iters : lrf::nerf::kDefaultNerfIters;
  n.checkpoint_every = o.checkpoint_every;
  n.rays = o.rays;
  n.samples = o.samples;
  n.log2_table = o.hash_log2;
  n.seed = o.seed;
  n.force = o.force;
  n.init_points = points;
  n.preset = o.preset;
  lrf::nerf::train_latent_nerf(n);
  return 0;
}

// --resume keeps the preset a run started with: asking for another is refused, not silently ignored.
void require_recorded_preset(const std::string& given, bool preset_given, const std::string& recorded,
                             const std::string& config_path) {
  if (!preset_given || given == recorded) return;
  lrf::fail_usage("--preset " + given + ": this run was started with --preset " + recorded + " (" + config_path +
                  ") and --resume keeps its recorded settings; drop --preset, or start a new run in another folder");
}

// The scene a resumed Gaussian field trains on: where its config.json records it (absolute, else relative to
// the run folder, so that a project folder moved as a whole resumes) or, when it is at neither place, the
// scene this command line names (`lrf train NEW_PLACE -o OUT --resume` after the scene alone moved), once it
// is seen to have the recorded numbers of training and test views.
std::string resumed_scene_root(const TrainOptions& given, const nlohmann::json& config, const std::string& path,
                               const lrf::SceneOptions& scene_options) {
  const std::string named = given.scene == given.out ? "" : given.scene;
  try {
    return lrf::resumed_run_scene_root(config, path, named, scene_options);
  } catch (const lrf::Error& e) {
    if (!named.empty()) throw;
    throw lrf::Error(std::string(e.what()) + " (lrf train: name it in place of the scene, `lrf train SCENE -o " +
                     given.out + " --resume`)");
  }
}

// --resume of a latent NeRF: its recorded options, except --steps, --checkpoint-every and --cache-dir when given.
int resume_train_nerf(const TrainOptions& given, bool iters_given, bool checkpoint_given, bool preset_given) {
  if (given.nerf_option_set)
    lrf::fail_usage("--rays, --samples and --hash-log2 are fixed when a latent NeRF starts; --resume keeps the recorded ones");
  auto n = lrf::nerf::recorded_nerf_options(given.out);
  require_recorded_preset(given.preset, preset_given, n.preset,
                          (std::filesystem::path(given.out) / "config.json").string());
  n.resume = true;
  if (iters_given) n.iters = given.iters;
  if (checkpoint_given) n.checkpoint_every = given.checkpoint_every;
  if (!given.cache_dir.empty()) n.cache_dir = given.cache_dir;
  lrf::nerf::train_latent_nerf(n);
  return 0;
}

lrf::RgbTrainOptions rgb_options(const TrainOptions& o, const lrf::InitPointsOptions& points) {
  lrf::RgbTrainOptions r;
  r.scene = o.scene;
  r.out = o.out;
  r.scene_options = o.scene_options;
  r.iters = o.iters;
  r.sh_degree = o.sh_degree;
  r.mip = o.mip;
  r.seed = o.seed;
  r.max_gaussians = o.max_gaussians;
  r.densify_grad = o.densify_grad;
  r.checkpoint_every = o.checkpoint_every;
  r.sparse_adam = o.sparse_adam;
  r.white_background = o.white_background;
  r.coarse_factor = o.coarse_factor;
  r.coarse_until = o.coarse_until;
  r.init_points = points;
  r.preset = o.preset;
  r.resume = o.resume;
  r.force = o.force;
  return r;
}

// --resume of an RGB field: its recorded options, except --steps and --checkpoint-every when given, and
// --cache-dir (where triangulated points are cached).
int resume_train_rgb(const TrainOptions& given, bool iters_given, bool checkpoint_given, bool preset_given) {
  const std::string path = (std::filesystem::path(given.out) / "config.json").string();
  const nlohmann::json stored = lrf::read_json_file(path);
  lrf::RgbTrainOptions r = lrf::recorded_rgb_options(given.out, stored);
  require_recorded_preset(given.preset, preset_given, r.preset, path);
  if (iters_given) r.iters = given.iters;
  if (checkpoint_given) r.checkpoint_every = given.checkpoint_every;
  r.init_points.cache_dir = given.init_points.cache_dir.empty() ? given.cache_dir : given.init_points.cache_dir;
  const std::string recorded = r.scene;
  r.scene = resumed_scene_root(given, stored, path, r.scene_options);
  if (r.scene == recorded && given.scene != r.scene && given.scene != given.out)
    lrf::log_warn("--resume: training on " + r.scene + " as recorded in " + path + " (not " + given.scene + ")");
  lrf::train_rgb_field(r);
  return 0;
}

// --resume of a latent (or feature) field continues the run as it was started: every setting comes from
// OUT/config.json except the ones given on this command line among --steps, --checkpoint-every and
// --cache-dir (which only says where encoded views are kept).
TrainOptions resumed_options(const TrainOptions& given, bool iters_given, bool checkpoint_given, bool preset_given) {
  const std::string path = (std::filesystem::path(given.out) / "config.json").string();
  auto stored = lrf::read_json_file(path);
  if (stored.contains("refine")) lrf::fail(path, "this folder holds a refined field: continue it with `lrf refine --resume`");
  TrainOptions o = given;
  try {
    const auto& j = stored.at("options");
    o.scene = j.at("scene").get<std::string>();
    const lrf::FieldKind kind = lrf::field_kind_of_config(stored, path);
    o.space = lrf::field_kind_name(kind);
    o.scene_options.images_dir = j.at("images").get<std::string>();
    o.scene_options.downscale = j.at("downscale").get<int>();
    o.scene_options.test_every = j.at("test_every").get<int>();
    o.scene_options.train_views = j.value("train_views", 0);
    o.sh_degree = j.at("sh_degree").get<int>();
    o.sh_degree_set = true;
    o.seed = j.at("seed").get<uint64_t>();
    o.max_gaussians = j.at("max_gaussians").get<int64_t>();
    o.densify_grad = j.value("densify_grad", lrf::splat::DensifyOptions{}.grad_threshold);  // runs before the option
    o.sparse_adam = j.at("sparse_adam").get<bool>();
    o.preset = j.value("preset", std::string(lrf::kDefaultPreset));  // runs from before presets had none
    require_recorded_preset(given.preset, preset_given, o.preset, path);
    if (!iters_given) o.iters = j.at("iters").get<int64_t>();
    if (!checkpoint_given) o.checkpoint_every = j.at("checkpoint_every").get<int64_t>();
    if (kind == lrf::FieldKind::latent) {
      o.autoencoder = j.at("autoencoder").get<std::string>();
      o.encoder = j.at("encoder").get<std::string>();
      o.init = j.at("init").get<std::string>();
      o.rgb_guide = j.value("rgb_guide", 0.0);
      o.feature_dim = j.value("feature_dim", 0);
      o.inria_rates = !j.value("short_run_rates", false);  // runs from before the short-run rates kept Inria's
    }
  } catch (const nlohmann::json::exception& e) {
    lrf::fail(path, std::string("cannot resume: missing or bad options: ") + e.what());
  }
  // Where the initial points came from (recorded by every run since they could be chosen): the resumed
  // run builds the same starting field before its checkpoint replaces it, and records the same origin.
  if (stored.contains("init_points") && stored["init_points"].is_object()) {
    o.init_points.mode = stored["init_points"].value("mode", std::string("auto"));
    if (stored["init_points"].contains("far_shell")) {
      o.init_points.shell.points = stored["init_points"]["far_shell"].value("lattice_points", 0);
      o.init_points.shell.radius_factor = stored["init_points"]["far_shell"].value("radius_factor", 2.0);
    }
  }
  const std::string recorded = o.scene;
  o.scene = resumed_scene_root(given, stored, path, o.scene_options);
  if (o.scene == recorded && given.scene != o.scene && given.scene != given.out)
    lrf::log_warn("--resume: training on " + o.scene + " as recorded in " + path + " (not " + given.scene + ")");
  return o;
}

int run_train(const TrainOptions& o) {
  using namespace lrf;
  using namespace lrf::splat;
  InitPointsOptions points = o.init_points;
  if (points.cache_dir.empty()) points.cache_dir = o.cache_dir;  // triangulated points live beside the latents
  check_init_points_mode(points.mode);
  const auto named = field_kind_named(o.space);
  if (!named) fail_usage("--space must be rgb, latent or latent-nerf, got '" + o.space + "'");
  const FieldKind kind = *named;
  // A fresh run written into its scene's folder would mix run files with the user's data (--force included).
  if (!o.resume && !o.out.empty()) refuse_output_over_input(o.out, o.scene, "the scene folder");
  if (o.rgb_guide != 0 && kind != FieldKind::latent) fail_usage("--rgb-guide applies to --space latent");
  if (o.inria_rates && kind != FieldKind::latent) fail_usage("--inria-rates applies to --space latent");
  if (o.coarse_factor < 1) fail_usage("--coarse-factor must be at least 1");
  if (o.coarse_until < -1) fail_usage("--coarse-until must be a step (or -1: where densification ends)");
  if ((o.coarse_factor != 1 || o.coarse_until != -1) && kind != FieldKind::rgb)
    fail_usage("--coarse-factor and --coarse-until apply to --space rgb");
  if (kind == FieldKind::latent_nerf) return run_train_nerf(o, points);
  if (o.nerf_option_set) fail_usage("--rays, --samples and --hash-log2 apply to --space latent-nerf");
  if (kind == FieldKind::latent) return run_train_latent(o, points);
  if (o.feature_dim != 0) fail_usage("--feature-dim applies to --space latent (a feature field lifted to the latent)");
  train_rgb_field(rgb_options(o, points));
  return 0;
}

// A fresh run (presets applied), or `lrf train OUT --resume`.
int train_or_resume(CLI::App* cmd, TrainOptions& o, bool iters_given, bool checkpoint_given, bool preset_given) {
  lrf::find_preset(lrf::train_presets(), o.preset);  // an unknown name is refused before anything else
  if (!o.resume) {
    if (o.out.empty()) lrf::fail_usage("--out is required (the folder to train into)");
    lrf::cli::apply_preset(cmd, lrf::train_presets(), o.preset, o.space);
    return run_train(o);
  }
  // `lrf train OUT --resume`: the recorded scene is used anyway, so the folder may stand in its place.
  if (o.out.empty()) o.out = o.scene;
  // An RGB field of lrf train, compare or pipeline (one job trains them all, so they are recorded alike).
  const auto kind = lrf::field_kind_of(o.out);
  if (kind == lrf::FieldKind::latent_nerf)
    return resume_train_nerf(o, iters_given, checkpoint_given, preset_given);
  if (kind == lrf::FieldKind::rgb) return resume_train_rgb(o, iters_given, checkpoint_given, preset_given);
  return run_train(resumed_options(o, iters_given, checkpoint_given, preset_given));
}

lrf::cli::CommandRegistration reg(20, [](CLI::App& root) {
  auto* cmd = root.add_subcommand("train", "Fit a Gaussian field (3D Gaussian splatting) to a scene");
  auto o = std::make_shared<TrainOptions>();
  cmd->add_option("scene", o->scene, "Scene folder (COLMAP, LLFF or NeRF transforms.json)")->required();
  cmd->add_option("--space", o->space,
                  "Feature space of the field: rgb (colours), latent (Stage II: the autoencoder's latents of the "
                  "views, cropped to multiples of 8, fitted at 1/8 resolution) or latent-nerf (a hash-grid NeRF "
                  "fitted to the same latents by volume rendering: the paper's Latent-NeRF* baseline)")
      ->check(CLI::IsMember({"rgb", "latent", "latent-nerf"}))
      ->capture_default_str();
  lrf::cli::add_autoencoder_option(cmd, &o->autoencoder, "of a latent field (latent, latent-nerf)");
  cmd->add_option("--encoder", o->encoder, "latent: fine-tuned encoder weights (Stage I) replacing the stock encoder");
  cmd->add_option("--init", o->init, "latent: starting features: latents (sampled from the training latents at the "
                                     "SfM points' projections) or rgb (the paper code's RGB-in-first-channels)")
      ->check(CLI::IsMember({"latents", "rgb"}))
      ->capture_default_str();
  cmd->add_option("--rgb-guide", o->rgb_guide,
                  "latent: weight of 3 extra channels fitted to the training images at latent resolution (8x "
                  "area-downsampled RGB) beside the latents and dropped when the field is written, so that the "
                  "geometry also follows the views' consistent colours (0 = latents alone, the paper's Stage II)")
      ->capture_default_str();
  cmd->add_option("--feature-dim", o->feature_dim,
                  "latent: fit a feature field instead (the feature-gs baseline, after Feature 3DGS's speed-up "
                  "module): Gaussians carrying D features, rendered at latent resolution and lifted to the latent "
                  "channels by a 1x1 convolution trained with them (OUT/lift.safetensors). Feature 3DGS's default "
                  "is half the latent channels: 16 for TAEF2. 0: a latent field")
      ->capture_default_str();
  cmd->add_option("--cache-dir", o->cache_dir, "Where encoded views (latent) and triangulated points are cached "
                                               "(default $LRF_CACHE or ~/.cache/lrf)");
  cmd->add_option("-o,--out", o->out, "Output folder (config.json, point_cloud.ply, train_log.csv); required unless "
                                     "--resume is given with the folder in place of the scene");
  lrf::cli::add_scene_options(cmd, &o->scene_options);
  lrf::cli::add_init_points_options(cmd, &o->init_points);
  auto* iters = cmd->add_option("--steps,--iters", o->iters,
                                "Training steps (default 30000; " + std::to_string(lrf::nerf::kDefaultNerfIters) +
                                    " for latent-nerf)")
                    ->each([o](const std::string&) { o->iters_set = true; });
  const auto nerf_option = [o](const std::string&) { o->nerf_option_set = true; };
  cmd->add_option("--rays", o->rays, "latent-nerf: rays per training step (drawn from every training pixel)")
      ->capture_default_str()
      ->each(nerf_option);
  cmd->add_option("--samples", o->samples,
                  "latent-nerf: coarse samples per ray (stratified in disparity), and as many fine ones drawn from "
                  "the coarse weights")
      ->capture_default_str()
      ->each(nerf_option);
  cmd->add_option("--hash-log2", o->hash_log2, "latent-nerf: log2 of the hash table's entries per grid level")
      ->capture_default_str()
      ->each(nerf_option);
  cmd->add_option("--sh-degree", o->sh_degree, "Largest spherical-harmonics degree (0-3; default 3 for rgb, " +
                                                   std::to_string(lrf::kDefaultLatentShDegree) + " for latent)")
      ->each([o](const std::string&) { o->sh_degree_set = true; });
  cmd->add_flag("--mip", o->mip, "Mip-Splatting: 3D smoothing filter and 2D Mip filter");
  cmd->add_option("--seed", o->seed, "Random seed (view order, initialisation, splits)")->capture_default_str();
  cmd->add_option("--max-gaussians", o->max_gaussians, "Cap on the number of Gaussians (0 = none)")
      ->capture_default_str();
  cmd->add_option("--densify-grad", o->densify_grad,
                  "Mean screen-space gradient (NDC units) above which a Gaussian is cloned or split; higher grows "
                  "a smaller field (Inria's 2e-4)")
      ->capture_default_str();
  cmd->add_flag("--inria-rates", o->inria_rates,
                "latent: keep Inria's learning rates in a run shorter than 7000 steps. By default such a run, whose "
                "densification schedule is compressed by steps/7000, moves the means and SH coefficients "
                "min(7000/steps, 4) times faster");
  cmd->add_flag("--resume", o->resume,
                "Continue the run in the output folder from its last checkpoint, with its recorded settings "
                "(--steps and --checkpoint-every may change). Any field lrf train, compare or pipeline trained "
                "continues so, e.g. `lrf train CMP/rgb_8 --resume --steps 14000`: the folder may stand in place of "
                "the scene and -o");
  cmd->add_flag("--force", o->force, "Overwrite an existing output folder");
  auto* checkpoint = cmd->add_option("--checkpoint-every", o->checkpoint_every, "Save a checkpoint every N steps")
      ->capture_default_str();
  cmd->add_flag("--sparse-adam", o->sparse_adam, "Skip the Adam update of Gaussians no pixel reached this step (faster; Inria uses a dense Adam)");
  cmd->add_flag("--white-background", o->white_background, "Composite on white instead of black");
  cmd->add_option("--coarse-factor", o->coarse_factor,
                  "rgb: train the first steps (up to --coarse-until) on the views reduced by this factor in width "
                  "and height (pixels area-averaged, intrinsics scaled), then on the full views. At 2 a coarse step "
                  "costs about a quarter and the whole run takes less time for some loss of detail (docs/results.md, 7000 "
                  "steps, four scenes: 0.5-0.7x the time, test PSNR 0-0.5 dB lower, SSIM 0.003-0.013 lower). "
                  "The logged PSNR is on the reduced views until then. 1: off")
      ->capture_default_str();
  cmd->add_option("--coarse-until", o->coarse_until,
                  "rgb: the last step of the coarse phase (-1: the step densification ends, half the run and at "
                  "most 15000). Later is faster: 5000 of 7000 steps fits fern in 8.6 min on 2 cores and scored as "
                  "the default end did")
      ->capture_default_str();
  auto* preset = lrf::cli::add_preset_option(cmd, lrf::train_presets(), &o->preset);
  lrf::cli::on_run(cmd, [cmd, o, iters, checkpoint, preset] {
    const int status = train_or_resume(cmd, *o, iters->count() > 0, checkpoint->count() > 0, preset->count() > 0);
    if (status == 0) lrf::cli::log_next_steps(o->out, "trained");
    return status;
  });
});

}  // namespace

