#pragma once
// Decoder-aware refinement of a fitted latent field (the RGB-alignment stage of latent NeRF work such as
// IG-AE and Latent-NeRF): Stage II fits the field to the encoded views, in latent space, where an error
// the decoder amplifies costs no more than one it ignores. Refinement keeps optimising the same Gaussians
// (means, shapes, opacities, latent features) through the frozen decoder against the scene's *training*
// images at full resolution, with 3DGS's image loss. The field stays a latent field: it renders latents
// at latent resolution, and decoding them is still the only way to an image.
//
// OUT is a latent run like any other (config.json, point_cloud.ply, checkpoint.pt, train_log.csv): it
// records the run it started from and the decoder it was refined through, which `lrf eval` / `render`
// then decode with unless told otherwise. Optionally the decoder adapts to the scene too (only ever on
// its training views): then OUT/decoder.safetensors is that decoder. Randomness (view order, windows) comes from (seed, step), so a
// resumed run ends where an uninterrupted one does.
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "lrf/core/run_control.h"

namespace lrf {

// out (RunControl): the refined run.
struct RefineOptions : RunControl {
  RefineOptions() { checkpoint_every = 500; }
  std::string run;      // a finished latent run (lrf train --space latent)
  std::string decoder;  // decoder to refine through ("" = the run's own: its autoencoder's, or the one it
                        //   was refined through)
  // The defaults below make the refined row of `lrf compare` a matter of minutes (issue 52; docs/results.md,
  // "Choosing the refinement's defaults"): chosen on fern's validation split (14 training views fitted, 3
  // held out), where 1000 steps of them (22.56 dB) score as the earlier 2000-step defaults (Stage II's rates,
  // the whole decoder adapted at 1e-4, densified until step 1000: 22.50 dB) at a quarter of their time.
  // 0 = kRefineStepsPerView steps per training view (refine_steps): on room's validation split (30 views)
  // the held-out views still gained 0.8 dB from 1000 to 2000 steps, where fern's levelled off near 1000.
  int64_t steps = 0;
  int crop = 0;          // side of the supervised square in image pixels (multiple of 8); 0 = the whole view
  // Multiplies Stage II's (Inria's) rates of features, opacities, scales, rotations. 2: on the validation
  // split +0.15 to +0.3 dB over 1 in the first 400 steps, level by 600; 4 no better than 2.
  double lr_scale = 2;
  double position_lr = 1.6e-6;  // of the means, x the scene extent (Stage II's final rate)
  // Multiplies the rates of the field's geometry (means, scales, rotations, opacities) on top of the
  // above: 0 keeps Stage II's geometry and adapts only the latent features (and the decoder), so that no
  // Gaussian can move to serve one training view alone.
  double geometry_lr_scale = 1;
  // Every rate (the decoder's with the field's) decays log-linearly to lr_final of itself by the last step,
  // starting at lr_decay_start of the run (0 = from the first step; lr_final 1 = constant rates). Default:
  // constant, then a decay in the last fifth. With constant rates the last step's result follows the last
  // views seen (flower's test views: 25.23 dB at step 1600, 24.88 at 1700); the tail decay scored above
  // constant rates at the same step on the validation splits of flower (+0.20 dB), fern (+0.15) and room
  // (+0.36 against the nearest constant-rate score), where a decay over the whole run cost 0.4 dB (room).
  double lr_final = 0.1;
  double lr_decay_start = 0.8;
  double lambda_ssim = 0.2;
  // > 0: the decoder is adapted to this scene with the field (Adam at this rate, on the same training
  // views); it is saved as OUT/decoder.safetensors and becomes the run's decoder. 0: frozen decoder.
  // Adapting it won on held-out views of dtu-scan37 (docs/results.md); 2e-4 goes with lr_scale 2 (5e-4 was
  // no better on the validation split).
  double decoder_lr = 2e-4;
  // > 0: only the decoder's layers working at most this many times the latent resolution adapt (1, 2, 4;
  // 8 or 0 = every layer). The layers above it are still trained through, to the field, but take no weight
  // gradient, which at full resolution is the largest part of a step's backward. Default 2: a step costs
  // 0.62 of one adapting every layer (bench_refine), and on the validation split 1000 such steps scored
  // 22.56 dB where 600 adapting every layer, in about the same time, scored 22.41 (1000 of those: 22.70,
  // in 1.6 times the time).
  int decoder_scale = 2;
  // > 0: the loss also holds the rendered latent near the encoded training view (L1 in the field's
  // normalised latent space, times this weight), so that the field stays a latent field of the scene
  // and not only of the training images' decoded pixels.
  double lambda_latent = 0;
  // > 0: each step renders its view through a camera shifted by (dx, dy) / 8 latent cells, dx and dy drawn
  // from 0..jitter pixels, and compares the decoded view with the training image moved by (dx, dy) pixels.
  // Without it a training view is only ever seen at one phase of the latent grid, so detail the field and
  // decoder place between latent cells need not hold for another camera; with jitter 7, at all 64. At most 7.
  // Default 7: +1.84 dB on the held-out views of fern's validation split, where the unjittered run falls
  // under rgb/8-mip; on beer-can's test views -0.34 dB PSNR, better SSIM, MS-SSIM and FLIP (docs/results.md).
  int jitter = 7;
  std::string cache_dir;  // latent cache of those encoded views ("" = $LRF_CACHE or ~/.cache/lrf)
  // > 0: Gaussians are still cloned and split (3DGS's rule on the image loss's screen-space gradient)
  // every densify_interval steps until this step; pruning of transparent ones goes on with it. Default 0:
  // at 2e-4 each densification splits a sixth of the field at once and the held-out views fall by up to
  // 4.6 dB, recovering over hundreds of steps (validation split: 21.23 dB at step 100, 16.64 at 200 after
  // the first one); densified until step 1000, 2000 steps end at 22.50 dB, where 600 undensified steps at
  // lr_scale 2 reach 22.46.
  int64_t densify_until = 0;
  int64_t densify_interval = 100;
  double densify_grad = 2e-4;
  uint64_t seed = 0;
  // > 0: every this many steps (and at the last) the field so far is scored on the scene's test views,
  // decoded by the decoder so far, into OUT/curve.csv: quality against the wall time of the whole row
  // (encode + Stage II + refinement so far; the scoring's own time is left out). Changes nothing else.
  int64_t score_every = 0;
};

struct RefineResult {
  int64_t steps = 0, gaussians = 0;
  double seconds = 0, last_loss = 0, last_psnr = 0;
};

// The default length in steps per training view: each view is seen about this many times, whatever the
// scene's size (fern: 17 views, 1000 steps; room: 35, 2100).
constexpr int64_t kRefineStepsPerView = 60;
// The length of a refinement of a field fitted on `train_views` views: options.steps, or with 0
// kRefineStepsPerView per view rounded to a hundred (at least 100).
int64_t refine_steps(const RefineOptions& options, int64_t train_views);
// `options` with a default length (steps 0) resolved for its source run, from the training views its
// config.json records; throws lrf::Error naming that file if it cannot be read.
RefineOptions with_refine_steps(RefineOptions options);

RefineResult refine_latent_field(const RefineOptions& options);

// The length of a refinement in words: "1000 steps", or "60 steps per training view" for the default.
std::string refine_length_text(const RefineOptions& options);

// The settings that shape a refined field, in words for tables' notes: "1000 steps at Stage II's rates x2,
// decoder adapted at Adam rate 0.0002 up to 2x the latent resolution, cameras jittered by up to 7 px".
std::string refine_description(const RefineOptions& options);

// The options as recorded in OUT/config.json under "refine"."options".
nlohmann::json refine_options_json(const RefineOptions& options);
// What decides a refined field (recorded as "refine"."resume_key"): the options without the checkpoint
// interval and the output (and without the length when the rates are constant, so that a resumed run may
// go on longer), with the source run's canonical path. A finished OUT whose key and length match is the
// same field.
nlohmann::json refine_resume_key(const RefineOptions& options);

}  // namespace lrf
