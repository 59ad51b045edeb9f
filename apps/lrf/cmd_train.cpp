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
#include "lrf/core/paths.h"
#include "lrf/field_kinds/field_type.h"
#include "lrf/latent/latent_run.h"
#include "lrf/latent/latent_train_run.h"
#include "lrf/nerf/nerf_run.h"
#include "lrf/nerf/nerf_train_run.h"

namespace {

// A fresh run in the kind of field --space names.
int run_train(const lrf::FieldTrainRequest& o) {
  using namespace lrf;
  const auto kind = field_kind_named(o.space);
  if (!kind) fail_usage("--space must be rgb, latent or latent-nerf, got '" + o.space + "'");
  // A fresh run written into its scene's folder would mix run files with the user's data (--force included).
  if (!o.resume && !o.out.empty()) refuse_output_over_input(o.out, o.scene, "the scene folder");
  if (o.coarse_factor < 1) fail_usage("--coarse-factor must be at least 1");
  if (o.coarse_until < -1) fail_usage("--coarse-until must be a step (or -1: where densification ends)");
  field_type(*kind).train(o);
  return 0;
}

// A fresh run (presets applied), or `lrf train OUT --resume`.
int train_or_resume(CLI::App* cmd, lrf::FieldTrainRequest& o, bool iters_given, bool checkpoint_given,
                    bool preset_given) {
  lrf::find_preset(lrf::train_presets(), o.preset);  // an unknown name is refused before anything else
  if (!o.resume) {
    if (o.out.empty()) lrf::fail_usage("--out is required (the folder to train into)");
    lrf::cli::apply_preset(cmd, lrf::train_presets(), o.preset, o.space);
    return run_train(o);
  }
  // `lrf train OUT --resume`: the recorded scene is used anyway, so the folder may stand in its place.
  if (o.out.empty()) o.out = o.scene;
  lrf::field_type_of(o.out).resume({o, iters_given, checkpoint_given, preset_given});
  return 0;
}

lrf::cli::CommandRegistration reg(20, [](CLI::App& root) {
  auto* cmd = root.add_subcommand("train", "Fit a Gaussian field (3D Gaussian splatting) to a scene");
  auto o = std::make_shared<lrf::FieldTrainRequest>();
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
  cmd->add_option("--hash-log2", o->log2_table, "latent-nerf: log2 of the hash table's entries per grid level")
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

