// lrf pipeline: Stage I -> Stage II -> Stage III on training scenes, then the ablation on unseen scenes.
#include <cstdio>
#include <memory>

#include "autoencoder_option.h"
#include "command.h"
#include "detail_options.h"
#include "preset_option.h"
#include "refine_options.h"
#include "lrf/core/atomic_file.h"
#include "lrf/pipeline/pipeline.h"

namespace {

lrf::cli::CommandRegistration reg(47, [](CLI::App& root) {
  auto* cmd = root.add_subcommand(
      "pipeline",
      "The paper's three stages and its ablation: Stage I (encoder) on the training scenes, latent fields with the "
      "stock and the new encoder, Stage III (decoder) on the training scenes' fields, then on the evaluation scenes "
      "the rows stock / encoder / decoder / both, the stock and both fields refined through their decoder "
      "(stock+refine, both+refine) and the image-space baselines rgb/8, rgb/8-mip, rgb and rgb-mip: DIR/ablation.csv, "
      "DIR/ablation.md (each scene's rows, then every row's mean over the evaluation scenes), DIR/report.html, DIR/stages.csv and stages.md (wall time per stage, from the stages' own "
      "records, over every session that worked on them), DIR/pipeline.json (inputs of every stage). Finished steps are reused and interrupted ones resumed when the same "
      "command is run again; a larger --refine-steps continues the finished refinements made at constant rates (--refine-lr-final 1) and "
      "scores their rows again");
  auto o = std::make_shared<lrf::PipelineOptions>();
  cmd->add_option("--train-scenes", o->train_scenes,
                  "Scenes for Stage I and Stage III; each a folder, optionally with its own resolution as for "
                  "--eval-scenes")
      ->required();
  cmd->add_option("--eval-scenes", o->eval_scenes,
                  "Unseen scenes the ablation is measured on, each a folder, optionally followed by its own "
                  "resolution: PATH:--images=DIR (the scene's image folder DIR, e.g. images_8), PATH:--downscale=N "
                  "(its images area-resized by N instead of --max-side's factor), or both "
                  "(PATH:--images=DIR:--downscale=N). Every field, refinement and score of the scene is made at it "
                  "(a folder made at another is refused). The tables add the mean over the evaluation scenes of "
                  "every row")
      ->required();
  cmd->add_option("-o,--output", o->out, "Output folder")->required();
  lrf::cli::add_autoencoder_option(cmd, &o->autoencoder, "of every stage");
  cmd->add_option("--max-side", o->max_side,
                  "Downscale each scene's images by the smallest integer factor bringing the longer side to at most "
                  "this many pixels (scenes given a :--downscale=N of their own use theirs)")
      ->capture_default_str();
  cmd->add_option("--field-steps,--field-iters", o->field_iters, "Training steps of every latent field and of the RGB baselines")
      ->capture_default_str();
  cmd->add_option("--stage1-steps", o->stage1.steps, "Stage I steps")->capture_default_str();
  cmd->add_option("--stage1-pairs", o->stage1.batch.pairs, "Stage I view pairs per step")->capture_default_str();
  cmd->add_option("--stage1-crop", o->stage1.batch.crop, "Stage I crop side (pixels)")->capture_default_str();
  cmd->add_option("--stage1-lr", o->stage1.lr, "Stage I Adam learning rate (0: paper's base rate x images per step)")
      ->capture_default_str();
  cmd->add_option("--lambda-corres", o->stage1.lambda_corres, "Stage I weight of the correspondence loss")
      ->capture_default_str();
  cmd->add_option("--lambda-reg", o->stage1.lambda_reg, "Stage I weight of the regulariser")->capture_default_str();
  cmd->add_option("--stage3-steps", o->stage3.steps, "Stage III steps (each decoder)")->capture_default_str();
  cmd->add_option("--stage3-lr", o->stage3.lr, "Stage III Adam learning rate (0: the paper's base rate x crops per step)")
      ->capture_default_str();
  cmd->add_option("--stage3-crop", o->stage3.crop, "Stage III crop side in pixels (a multiple of 8)")
      ->capture_default_str();
  cmd->add_option("--stage3-lambda-ssim", o->stage3.lambda_ssim,
                  "Stage III: mix each term's L1 with D-SSIM, (1 - lambda) L1 + lambda (1 - SSIM) (0: the paper's pure L1)")
      ->capture_default_str();
  cmd->add_option("--stage3-weight-roundtrip", o->stage3.weight_roundtrip,
                  "Stage III: weight of an L1 term on encoded training images that keeps the decoder decoding ordinary "
                  "latents (0: none, the paper's loss, which on three LLFF scenes lost 0.5 dB against the stock decoder "
                  "where this default gained 0.5)")
      ->capture_default_str();
  cmd->add_option("--seed", o->seed, "Seed of every stage")->capture_default_str();
  cmd->add_option("--eval-train-views", o->eval_train_views,
                  "Few-shot protocol on the evaluation scenes (the paper's Table 2 uses 3): their fields train on only K "
                  "views, evenly spaced over the non-test views, with initial points triangulated from the K; training "
                  "scenes keep every view (0: all). Its evaluation fields, scores and tables are its own (fields/<scene>-Kviews-*, "
                  "eval/<scene>-Kviews, ablation-Kviews.csv/.md, stages-Kviews.csv/.md, report-Kviews.html, "
                  "pipeline-Kviews.json), beside the full protocol's in the same folder: Stage I, Stage III and the "
                  "training scenes' fields are reused")
      ->capture_default_str();
  cmd->add_option("--lpips-weights", o->lpips_weights, "LPIPS (v0.1 VGG) weights; without them LPIPS is not computed");
  cmd->add_option("--cache-dir", o->cache_dir, "Latent cache folder (default: $LRF_CACHE or ~/.cache/lrf)");
  lrf::cli::add_refine_options(cmd, &o->refine, "the +refine rows");
  cmd->add_flag("!--no-rgb", o->rgb_baseline, "Skip the image-space baselines (rgb/8, rgb/8-mip, and rgb, rgb-mip if asked)");
  cmd->add_flag("--rgb-full", o->rgb_full,
                "Add the rgb and rgb-mip rows: RGB fields at full resolution, without and with Mip-Splatting's filters "
                "(upper references, and Table 2's 3DGS and Mip-Splatting rows; the costliest fields to train)");
  cmd->add_flag("!--no-refine", o->refine_rows, "Skip the refined rows (stock+refine, both+refine, both+refine+detail)");
  cmd->add_flag("!--no-detail", o->detail_row,
                "Skip the both+refine+detail row (the both+refine field's frames with the detail pass: its nearest "
                "training photographs carried into each test view with its depth and blended in where they agree)");
  lrf::cli::add_detail_options(cmd, &o->detail);
  auto shard = std::make_shared<std::string>();
  cmd->add_option("--shard", *shard,
                  "i/n: run only the i-th of n shares of the per-scene steps (field fits and their refinements and "
                  "evaluations) whose inputs are finished, e.g. as a Slurm array; never Stage I, Stage III or the "
                  "tables. The same command without --shard then reuses everything the shards finished and does the "
                  "rest");
  auto preset = std::make_shared<std::string>();
  lrf::cli::add_preset_option(cmd, lrf::pipeline_presets(), preset.get());
  lrf::cli::on_run(cmd, [cmd, o, shard, preset] {
    lrf::cli::apply_preset(cmd, lrf::pipeline_presets(), *preset);
    if (!shard->empty()) lrf::parse_shard(*shard, o.get());
    auto record = lrf::run_pipeline(*o);
    if (o->shard_count > 1) {
      std::printf("%s: %zu unit(s) done, %zu left for the unsharded command\n",
                  record["shard"].get<std::string>().c_str(), record["done"].size(), record["left"].size());
      return 0;
    }
    std::printf("%s", lrf::read_file(record["table"].get<std::string>()).c_str());
    return 0;
  });
});

}  // namespace
