#pragma once
// The refinement's options as `compare` and `pipeline` expose them (--refine-*), for the refined rows
// they add; `lrf refine` itself has the same options without the prefix.
#include <string>

#include <CLI/CLI.hpp>

#include "lrf/refine/refine.h"

namespace lrf::cli {

// `rows` names the rows the options apply to in the help text (e.g. "latent-refined").
inline void add_refine_options(CLI::App* cmd, RefineOptions* o, const std::string& rows) {
  const std::string p = rows + ": ";
  cmd->add_option("--refine-steps", o->steps, p + "refinement steps (one training view each; 0 = " + std::to_string(kRefineStepsPerView) +
                      " per training view)")->capture_default_str();
  cmd->add_option("--refine-crop", o->crop, p + "supervised square per step in pixels (0 = whole view)")
      ->capture_default_str();
  cmd->add_option("--refine-lr-scale", o->lr_scale, p + "multiplies Stage II's learning rates")->capture_default_str();
  cmd->add_option("--refine-lr-final", o->lr_final,
                  p + "every rate, the decoder's with the field's, decays log-linearly to this fraction of itself by "
                      "the last step (1 = constant rates, with which a finished refinement is continued when more "
                      "--refine-steps are asked for)")
      ->capture_default_str();
  cmd->add_option("--refine-lr-decay-start", o->lr_decay_start,
                  p + "the rates stay constant for this fraction of the run and decay in the rest (0 = from the "
                      "first step)")
      ->capture_default_str();
  cmd->add_option("--refine-geometry-lr-scale", o->geometry_lr_scale,
                  p + "multiplies the rates of means, scales, rotations and opacities (0 = Stage II's geometry "
                      "stays)")
      ->capture_default_str();
  cmd->add_option("--refine-decoder-lr", o->decoder_lr,
                  p + "Adam rate at which the decoder adapts to the scene's training views with the field "
                      "(0 = frozen decoder)")
      ->capture_default_str();
  cmd->add_option("--refine-densify-until", o->densify_until,
                  p + "keep cloning / splitting Gaussians on the image loss's gradient until this step (0 = the "
                      "field keeps Stage II's Gaussians)")
      ->capture_default_str();
  cmd->add_option("--refine-decoder-scale", o->decoder_scale,
                  p + "adapt only the decoder's layers that work at most this many times the latent resolution "
                      "(1, 2, 4; 0 or 8 = every layer)")
      ->capture_default_str();
  cmd->add_option("--refine-score-every", o->score_every,
                  p + "every N refinement steps, score the test views into the refined run's curve.csv (PSNR, SSIM, "
                      "MS-SSIM, FLIP against the wall time of encode + fit + refine so far; 0 = off); changes "
                      "nothing in the field")
      ->capture_default_str();
  cmd->add_option("--refine-jitter", o->jitter,
                  p + "shift each step's camera and image by a random 0..N pixels (0 = off, at most 7)")
      ->capture_default_str();
}

}  // namespace lrf::cli
