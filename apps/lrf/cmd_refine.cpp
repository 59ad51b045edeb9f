// lrf refine: decoder-aware refinement of a fitted latent field against the training images.
#include <cstdio>
#include <memory>

#include "command.h"
#include "lrf/refine/refine.h"
#include "scene_override_option.h"

namespace {

lrf::cli::CommandRegistration reg(23, [](CLI::App& root) {
  auto* cmd = root.add_subcommand(
      "refine",
      "Refine a fitted latent field through the decoder: keep optimising its Gaussians so that their rendered "
      "latents decode into the scene's training images at full resolution (3DGS's 0.8 L1 + 0.2 D-SSIM image "
      "loss), by default adapting the decoder's coarse layers to those views with them. Writes a new latent run "
      "to OUT that `lrf eval` / `render` decode with the decoder it was refined through; checkpoints, progress, "
      "--resume");
  auto o = std::make_shared<lrf::RefineOptions>();
  cmd->add_option("run", o->run, "A finished latent field (`lrf train --space latent` folder)")->required();
  cmd->add_option("-o,--out", o->out, "Output folder of the refined field")->required();
  lrf::cli::add_scene_override_option(cmd);
  cmd->add_option("--decoder", o->decoder,
                  "Decoder weights to refine through, e.g. Stage III's (default: the run's own decoder)");
  cmd->add_option("--steps", o->steps,
                  "Optimisation steps (one training view each); 0 = " + std::to_string(lrf::kRefineStepsPerView) +
                      " per training view of the field, rounded to a hundred (fern: 1000)")
      ->capture_default_str();
  cmd->add_option("--crop", o->crop,
                  "Side in pixels (multiple of 8) of a random square of the view supervised per step, decoded "
                  "exactly with the decoder's context around it; 0 = the whole view")
      ->capture_default_str();
  cmd->add_option("--lr-scale", o->lr_scale,
                  "Multiplies Stage II's learning rates of features, opacities, scales and rotations")
      ->capture_default_str();
  cmd->add_option("--position-lr", o->position_lr, "Learning rate of the means, times the scene extent")
      ->capture_default_str();
  cmd->add_option("--geometry-lr-scale", o->geometry_lr_scale,
                  "Multiplies the learning rates of the means, scales, rotations and opacities (0 = Stage II's "
                  "geometry stays, only the latent features and the decoder adapt)")
      ->capture_default_str();
  cmd->add_option("--lr-final", o->lr_final,
                  "Every learning rate, the decoder's with the field's, decays log-linearly to this fraction of itself by the "
                  "last step (1 = constant rates). The default decay in the last fifth keeps the result from following "
                  "the last views seen")
      ->capture_default_str();
  cmd->add_option("--lr-decay-start", o->lr_decay_start,
                  "With --lr-final below 1: the rates stay constant for this fraction of the run and decay in the "
                  "rest (0 = from the first step)")
      ->capture_default_str();
  cmd->add_option("--decoder-lr", o->decoder_lr,
                  "Also adapt the decoder to this scene's training views, with Adam at this rate (0 = frozen); the "
                  "adapted decoder is written to OUT/decoder.safetensors and decodes the refined field")
      ->capture_default_str();
  cmd->add_option("--decoder-scale", o->decoder_scale,
                  "With --decoder-lr: adapt only the decoder's layers that work at most this many times the latent "
                  "resolution (1, 2, 4; 0 or 8 = every layer). The others are trained through but take no weight "
                  "gradient, the largest part of a whole view's backward")
      ->capture_default_str();
  cmd->add_option("--lambda-latent", o->lambda_latent,
                  "Weight of an L1 term holding the rendered latent near the encoded training view (normalised "
                  "latent space; 0 = image loss only; needs --jitter 0, as the encoded views are of unshifted cameras)")
      ->capture_default_str();
  cmd->add_option("--jitter", o->jitter,
                  "Shift each step's camera by a random 0..N pixels in x and y (N/8 of a latent cell) and the "
                  "training image with it, so that the field is fitted at every phase of the latent grid (0 = off, "
                  "at most 7)")
      ->capture_default_str();
  cmd->add_option("--cache-dir", o->cache_dir,
                  "Latent cache of the encoded training views that --lambda-latent needs (default: $LRF_CACHE or "
                  "~/.cache/lrf)");
  cmd->add_option("--densify-until", o->densify_until,
                  "Keep cloning / splitting Gaussians (3DGS's rule on the image loss's gradient) until this step "
                  "(0 = the field's size stays as Stage II left it)")
      ->capture_default_str();
  cmd->add_option("--densify-interval", o->densify_interval, "Steps between densifications (with --densify-until)")
      ->capture_default_str();
  cmd->add_option("--densify-grad", o->densify_grad,
                  "Mean screen-space gradient above which a Gaussian is cloned or split (with --densify-until)")
      ->capture_default_str();
  cmd->add_option("--lambda-ssim", o->lambda_ssim, "Weight of the D-SSIM term of the image loss")->capture_default_str();
  cmd->add_option("--seed", o->seed, "Seed of the view order and window positions")->capture_default_str();
  cmd->add_option("--checkpoint-every", o->checkpoint_every, "Save a checkpoint every N steps")->capture_default_str();
  cmd->add_option("--score-every", o->score_every,
                  "Every N steps (and at the last), score the field so far on the scene's test views into "
                  "OUT/curve.csv: PSNR, SSIM, MS-SSIM and FLIP against the wall time of encode + Stage II + "
                  "refinement so far (the scoring's own time left out; 0 = off). Changes nothing in the field")
      ->capture_default_str();
  cmd->add_flag("--resume", o->resume, "Continue OUT from its last checkpoint (same options; --steps may grow when --lr-final is 1)");
  cmd->add_flag("--force", o->force, "Overwrite an existing output folder");
  lrf::cli::on_run(cmd, [o] {
    lrf::RefineResult r = lrf::refine_latent_field(*o);
    std::printf("refine: %lld steps, %lld Gaussians, last loss %.5f, last training-view PSNR %.2f dB, %.1f s\n",
                static_cast<long long>(r.steps), static_cast<long long>(r.gaussians), r.last_loss, r.last_psnr,
                r.seconds);
    return 0;
  });
});

}  // namespace
