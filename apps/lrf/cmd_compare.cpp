// lrf compare: the paper's Table 1 rows on one scene, in one command.
#include <cstdio>
#include <fstream>
#include <memory>

#include "autoencoder_option.h"
#include "command.h"
#include "detail_options.h"
#include "preset_option.h"
#include "refine_options.h"
#include "init_points_options.h"
#include "lrf/core/atomic_file.h"
#include "lrf/compare/compare.h"
#include "lrf/nerf/nerf_run.h"
#include "lrf/nerf/nerf_train_run.h"
#include "lrf/feature/feature_lift.h"

namespace {

lrf::cli::CommandRegistration reg(25, [](CLI::App& root) {
  auto* cmd = root.add_subcommand(
      "compare",
      "Table 1 on one scene: rgb/8, rgb/8-mip, latent and refined latent fields (and the full-resolution rgb and "
      "rgb-mip fields, a latent NeRF and the feature-gs baseline on request), scored on the test views; writes DIR/table.csv, table.md, the efficiency table "
      "(what each method is fitted to, training time, peak memory, storage, render and decode FPS) efficiency.csv, "
      "efficiency.md, and report.html");
  auto o = std::make_shared<lrf::CompareOptions>();
  cmd->add_option("scene", o->scene, "Scene folder")->required();
  cmd->add_option("-o,--out", o->out, "Output folder (one subfolder per method; finished methods are reused; latent-refined only if made with the same --refine-* options, and continued if more --refine-steps are asked for at constant rates, --refine-lr-final 1)")->required();
  cmd->add_option("--images", o->scene_options.images_dir, "Image folder inside the scene, e.g. images_8");
  cmd->add_option("--downscale", o->scene_options.downscale, "Area-downscale the images by this factor")->capture_default_str();
  cmd->add_option("--test-every", o->scene_options.test_every, "Hold out every N-th view for testing")->capture_default_str();
  cmd->add_option("--train-views", o->scene_options.train_views,
                  "Few-shot protocol (the paper's Table 2 uses 3): every method trains on only K views, evenly spaced "
                  "over the non-test views; test views unchanged; initial points triangulated from the K (0: all)")
      ->capture_default_str();
  lrf::cli::add_autoencoder_option(cmd, &o->autoencoder, "of the latent rows");
  cmd->add_option("--encoder", o->encoder, "Fine-tuned encoder weights for the latent field (Stage I)");
  cmd->add_option("--decoder", o->scoring.decoder,
                  "Decoder weights to decode the latent field with, and to refine it through (Stage III)");
  cmd->add_option("--steps,--iters", o->iters, "Training steps of every method")->capture_default_str();
  cmd->add_option("--latent-steps,--latent-iters", o->latent_iters, "Training steps of the latent field (0 = --steps)")->capture_default_str();
  cmd->add_option("--nerf-steps,--nerf-iters", o->nerf_iters,
                  "Training steps of the latent-nerf method (0 = its default, " +
                      std::to_string(lrf::nerf::kDefaultNerfIters) + "; --steps counts Gaussian fields' steps)")
      ->capture_default_str();
  cmd->add_option("--latent-sh-degree", o->latent_sh_degree, "SH degree of the latent field")->capture_default_str();
  cmd->add_option("--methods", o->methods,
                  "Methods to run: rgb, rgb-mip (full resolution, without / with Mip-Splatting's filters), rgb/8, "
                  "rgb/8-mip (RGB fields on 8x downscaled views), latent, "
                  "latent-refined (the latent field refined through the decoder against the training images), "
                  "latent-refined+detail (that field's frames with the detail pass: the nearest training photographs "
                  "carried into each view with the field's depth, blended in where they agree; --detail-*), "
                  "latent-nerf (a hash-grid NeRF fitted to the same latents by volume rendering: Latent-NeRF*), "
                  "feature-gs (Feature 3DGS's idea: a low-dimensional feature field lifted to the latent by a 1x1 "
                  "convolution trained with it)")
      ->capture_default_str();
  lrf::cli::add_refine_options(cmd, &o->refine, "latent-refined");
  lrf::cli::add_detail_options(cmd, &o->scoring.detail);
  cmd->add_option("--feature-dim", o->feature_dim,
                  "feature-gs: features per Gaussian (0: Feature 3DGS's default, half the latent channels, 16 for TAEF2)")
      ->check(CLI::Range(0, lrf::kMaxFeatureDim))
      ->capture_default_str();
  cmd->add_option("--curve", o->curves,
                  "NAME=CSV: a quality curve of another run (the curve.csv of lrf refine --score-every) drawn in the "
                  "report's chart beside this run's latent-refined curve (with --refine-score-every); repeatable");
  cmd->add_option("--lpips-weights", o->scoring.lpips_weights, "LPIPS weights (lpips v0.1 VGG layout); without: lpips empty");
  cmd->add_option("--cache-dir", o->cache_dir, "Latent cache folder (default $LRF_CACHE or ~/.cache/lrf)");
  cmd->add_option("--seed", o->seed, "Random seed")->capture_default_str();
  cmd->add_flag("--force", o->force, "Retrain and re-score every method instead of reusing finished ones");
  lrf::cli::add_init_points_options(cmd, &o->init_points);
  auto preset = std::make_shared<std::string>();
  lrf::cli::add_preset_option(cmd, lrf::compare_presets(), preset.get());
  lrf::cli::on_run(cmd, [cmd, o, preset] {
    lrf::cli::apply_preset(cmd, lrf::compare_presets(), *preset);
    if (o->init_points.cache_dir.empty()) o->init_points.cache_dir = o->cache_dir;  // triangulated points beside the latents
    lrf::check_init_points_mode(o->init_points.mode);
    lrf::run_compare(*o);
    std::printf("%s", lrf::read_file(o->out + "/table.md").c_str());
    return 0;
  });
});

}  // namespace
