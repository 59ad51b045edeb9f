// lrf finetune-encoder: Stage I, correspondence-aware fine-tuning of an autoencoder's encoder.
#include <cstdio>
#include <memory>

#include "autoencoder_option.h"
#include "command.h"
#include "distributed_flags.h"
#include "lrf/finetune/encoder_finetune.h"
#include "lrf/scene/scene_spec.h"

namespace {

// --scenes PATH:--images=DIR:--downscale=N: the paths stay in `scenes`; the resolutions are recorded only
// when some scene has one, as lrf pipeline records its Stage I.
void split_scene_specs(lrf::EncoderFinetuneOptions& o) {
  std::vector<lrf::SceneResolution> resolutions;
  bool any = false;
  for (std::string& argument : o.scenes) {
    const lrf::SceneSpec spec = lrf::parse_scene_spec(argument);
    lrf::check_scene_spec_folders(spec, argument);
    any = any || !spec.resolution.is_default();
    resolutions.push_back(spec.resolution);
    argument = spec.path;
  }
  if (any) o.scene_resolutions = resolutions;
}

lrf::cli::CommandRegistration reg(45, [](CLI::App& root) {
  auto* cmd = root.add_subcommand(
      "finetune-encoder",
      "Stage I: fine-tune an autoencoder's encoder on posed multi-view scenes so that latents of the same 3D point "
      "agree across views (loss L_VAE + lambda1 L_corres + lambda2 L_reg, decoder frozen). Writes the encoder as "
      ".safetensors (use it with --encoder), a run record OUT.json, and a checkpoint OUT.checkpoint.safetensors that "
      "--resume continues from. Data parallel over several processes or hosts: start it with `lrf launch -n N --` or "
      "srun; --pairs stays the global batch");
  auto o = std::make_shared<lrf::EncoderFinetuneOptions>();
  cmd->add_option("--scenes", o->scenes,
                  "Training scenes (COLMAP, LLFF or NeRF folders with poses), each optionally followed by its own "
                  "resolution as in lrf pipeline: PATH:--images=DIR (the scene's image folder DIR, e.g. "
                  "images_masked), PATH:--downscale=N (its images area-resized by N instead of --max-side's "
                  "factor), or both")
      ->required();
  cmd->add_option("-o,--output", o->out, "Fine-tuned encoder to write (.safetensors)")->required();
  lrf::cli::add_autoencoder_option(cmd, &o->autoencoder, "whose encoder is fine-tuned");
  cmd->add_option("--encoder", o->encoder, "Start from this encoder checkpoint instead of the autoencoder's own");
  cmd->add_option("--correspondences", o->correspondence_files,
                  "Correspondence files from `lrf corr ... --crop8` at the resolution used, one per scene in order "
                  "(default: computed from COLMAP tracks, else SCENE/database.db, else lrf's SIFT matcher)");
  cmd->add_option("--max-side", o->max_side,
                  "Downscale each scene by the smallest integer factor that brings its longer side to at most this "
                  "many pixels (0: full resolution)")
      ->capture_default_str();
  cmd->add_option("--min-matches", o->min_matches, "Drop view pairs with fewer correspondences")->capture_default_str();
  cmd->add_option("--steps", o->steps, "Optimisation steps")->capture_default_str();
  cmd->add_option("--pairs", o->batch.pairs, "View pairs per step (two images each)")->capture_default_str();
  cmd->add_option("--crop", o->batch.crop,
                  "Square crop side in pixels (multiple of 8; the paper uses 512), reduced to the smallest image side")
      ->capture_default_str();
  cmd->add_option("--max-matches", o->batch.max_matches, "Correspondences used per pair and step (random subset)")
      ->capture_default_str();
  cmd->add_option("--lambda-corres", o->lambda_corres, "Weight lambda1 of the correspondence loss")->capture_default_str();
  cmd->add_option("--lambda-reg", o->lambda_reg,
                  "Weight lambda2 of the regulariser keeping latents near the original encoder's (lower: more "
                  "consistent latents, but a decoder round trip that degrades faster)")
      ->capture_default_str();
  cmd->add_option("--kl-weight", o->kl_weight, "KL-VAE only: weight of the posterior's KL to N(0, I) in L_VAE")
      ->capture_default_str();
  cmd->add_option("--base-lr", o->base_lr,
                  "Base learning rate; Adam's rate is base-lr x images per step (as the paper's ldm config scales it)")
      ->capture_default_str();
  cmd->add_option("--lr", o->lr, "Adam's learning rate, overriding --base-lr scaling (0: use --base-lr)")
      ->capture_default_str();
  cmd->add_option("--seed", o->seed, "Seed of the batch sampling (and KL-VAE posterior samples)")->capture_default_str();
  cmd->add_option("--checkpoint-every", o->checkpoint_every, "Write the checkpoint every N steps")->capture_default_str();
  cmd->add_flag("--resume", o->resume, "Continue from OUT.checkpoint.safetensors (same options; --steps may grow)");
  cmd->add_flag("--force", o->force, "Overwrite an existing output (starting afresh)");
  auto dist = std::make_shared<lrf::DistributedOptions>();
  lrf::cli::add_distributed_flags(cmd, dist.get());
  lrf::cli::on_run(cmd, [o, dist] {
    split_scene_specs(*o);
    o->distributed = lrf::cli::resolve_distributed_flags(*dist);
    lrf::EncoderFinetuneResult r = lrf::finetune_encoder(*o);
    if (!r.main_rank) return 0;
    std::printf("finetune-encoder: %lld steps, last loss %.5f (vae %.5f, corres %.5f, reg %.6f), %.1f s\n",
                static_cast<long long>(r.steps), r.last_total, r.last_vae, r.last_corres, r.last_reg, r.seconds);
    return 0;
  });
});

}  // namespace
