// lrf finetune-decoder: Stage III, aligning the decoder with what latent fields render.
#include <cstdio>
#include <memory>

#include "autoencoder_option.h"
#include "command.h"
#include "distributed_flags.h"
#include "lrf/finetune/decoder_finetune.h"

namespace {

lrf::cli::CommandRegistration reg(46, [](CLI::App& root) {
  auto* cmd = root.add_subcommand(
      "finetune-decoder",
      "Stage III: fine-tune an autoencoder's decoder on latents rendered by fitted latent fields (their training and "
      "held-out views) against the real images: weight-train x L1_train + weight-novel x L1_novel + weight-roundtrip "
      "x L1 of the training images encoded and decoded, encoder untouched. "
      "Writes the decoder as .safetensors (use it with --decoder), a run record OUT.json, and a checkpoint "
      "OUT.checkpoint.safetensors that --resume continues from. Data parallel over several processes or hosts: start it "
      "with `lrf launch -n N --` or srun; --batch stays the global batch");
  auto o = std::make_shared<lrf::DecoderFinetuneOptions>();
  cmd->add_option("--fields", o->fields, "Finished latent fields (`lrf train --space latent` folders)")->required();
  cmd->add_option("-o,--output", o->out, "Fine-tuned decoder to write (.safetensors)")->required();
  lrf::cli::add_autoencoder_option(cmd, &o->autoencoder, "the fields were trained with");
  cmd->add_option("--encoder", o->encoder, "Encoder checkpoint the fields were trained with (e.g. from Stage I)");
  cmd->add_option("--decoder", o->decoder, "Start from this decoder checkpoint instead of the autoencoder's own");
  cmd->add_option("--steps", o->steps, "Optimisation steps")->capture_default_str();
  cmd->add_option("--batch", o->batch, "Crops per step from training views, and as many from held-out views")
      ->capture_default_str();
  cmd->add_option("--crop", o->crop, "Image crop side in pixels (multiple of 8), reduced to the smallest view")
      ->capture_default_str();
  cmd->add_option("--weight-train", o->weight_train, "Weight of the L1 on training views")->capture_default_str();
  cmd->add_option("--weight-novel", o->weight_novel, "Weight of the L1 on held-out (novel) views")->capture_default_str();
  cmd->add_option("--lambda-ssim", o->lambda_ssim,
                  "Mix each term's L1 with D-SSIM: (1 - lambda) L1 + lambda (1 - SSIM), as 3DGS does (0: the paper's "
                  "pure L1)")
      ->capture_default_str();
  o->weight_roundtrip = lrf::kRecommendedWeightRoundtrip;
  cmd->add_option("--weight-roundtrip", o->weight_roundtrip,
                  "Weight of a third L1 term on crops of the training images encoded by the frozen encoder, which "
                  "keeps the decoder decoding ordinary latents (0: none, the paper's loss; the default was chosen on "
                  "validation splits of three LLFF scenes, where the paper's loss lost 0.6 dB and this weight gained "
                  "0.4 dB over the stock decoder)")
      ->capture_default_str();
  cmd->add_option("--base-lr", o->base_lr, "Base learning rate; Adam's rate is base-lr x crops per step")
      ->capture_default_str();
  cmd->add_option("--lr", o->lr, "Adam's learning rate, overriding --base-lr scaling (0: use --base-lr)")
      ->capture_default_str();
  cmd->add_option("--seed", o->seed, "Seed of the crop sampling")->capture_default_str();
  cmd->add_option("--checkpoint-every", o->checkpoint_every, "Write the checkpoint every N steps")->capture_default_str();
  cmd->add_flag("--resume", o->resume, "Continue from OUT.checkpoint.safetensors (same options; --steps may grow)");
  cmd->add_flag("--force", o->force, "Overwrite an existing output (starting afresh)");
  auto dist = std::make_shared<lrf::DistributedOptions>();
  lrf::cli::add_distributed_flags(cmd, dist.get());
  lrf::cli::on_run(cmd, [o, dist] {
    o->distributed = lrf::cli::resolve_distributed_flags(*dist);
    lrf::DecoderFinetuneResult r = lrf::finetune_decoder(*o);
    if (!r.main_rank) return 0;
    std::printf("finetune-decoder: %lld steps on %lld training + %lld held-out rendered views, last loss %.5f "
                "(train %.5f, novel %.5f), %.1f s\n",
                static_cast<long long>(r.steps), static_cast<long long>(r.train_samples),
                static_cast<long long>(r.novel_samples), r.last_loss, r.last_train, r.last_novel, r.seconds);
    return 0;
  });
});

}  // namespace
