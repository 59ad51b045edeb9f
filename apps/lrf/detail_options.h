#pragma once
// The detail pass's options (--detail-*), bound straight onto lrf::detail::DetailOptions, for every command
// that can apply it.
#include <CLI/CLI.hpp>

#include "lrf/detail/detail_blend.h"

namespace lrf::cli {

inline void add_detail_options(CLI::App* cmd, detail::DetailOptions* o) {
  cmd->add_option("--detail-views", o->views, "Detail pass: training photographs borrowed per frame, nearest first")
      ->check(CLI::Range(1, 32))
      ->capture_default_str();
  cmd->add_option("--detail-blur", o->blur_sigma,
                  "Detail pass: the blur (Gaussian sigma, pixels) at which a photograph's colours must agree with "
                  "the decoded view's to be trusted")
      ->check(CLI::Range(0.3, 50.0))
      ->capture_default_str();
  cmd->add_option("--detail-agreement", o->agreement,
                  "Detail pass: mean colour difference (0..1) of the blurred images at which a photograph's "
                  "trust falls to 1/e")
      ->check(CLI::Range(1e-4, 1.0))
      ->capture_default_str();
  cmd->add_option("--detail-decoded-weight", o->decoded_weight,
                  "Detail pass: the decoded view's own weight beside each fully trusted photograph's 1; used as "
                  "given only with --detail-calibration-views 0")
      ->check(CLI::Range(1e-4, 1e4))
      ->capture_default_str();
  cmd->add_option("--detail-calibration-views", o->calibration_views,
                  "Detail pass: training views on which the decoded weight is chosen for this field (each one's "
                  "frame is blended with its nearest other photographs and scored against its own); a field "
                  "whose decoder is sharp enough may do best without the photographs and is then shown as it "
                  "is. 0 = take --detail-decoded-weight as given")
      ->check(CLI::Range(0, 64))
      ->capture_default_str();
  cmd->add_flag("--detail-learn", o->learned_blend,
                "Detail pass: learn the blend for this field on its training views (each rebuilt from its nearest "
                "other photographs; a small network on the CPU, under a minute), kept only where it beats the "
                "hand-made blend on training views it did not learn on");
  cmd->add_option("--detail-learning-views", o->learning_views,
                  "Detail pass: training views --detail-learn learns on and is judged on (every fourth held out)")
      ->check(CLI::Range(4, 256))
      ->capture_default_str();
  cmd->add_option("--detail-learning-steps", o->learning_steps, "Detail pass: Adam steps of --detail-learn")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  cmd->add_option("--detail-occlusion", o->occlusion_tolerance,
                  "Detail pass: fraction of its depth a point may lie behind the surface a photograph's camera "
                  "sees there and still be taken as seen by it")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--detail-consistency", o->consistency,
                  "Detail pass: spread of the photographs' colours (std over a 5x5 window, 0..1) at which a pixel's "
                  "trust in all of them falls to 1/e (0 = not used)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--detail-sweep", o->sweep_range,
                  "Detail pass: refine the field's depth per pixel within this fraction of itself, to where the "
                  "borrowed photographs agree best (0 = the field's depth as rendered)")
      ->check(CLI::Range(0.0, 0.5))
      ->capture_default_str();
  cmd->add_option("--detail-sweep-steps", o->sweep_steps, "Detail pass: depths tried per pixel by --detail-sweep")
      ->check(CLI::Range(2, 65))
      ->capture_default_str();
  cmd->add_option("--detail-sweep-window", o->sweep_window,
                  "Detail pass: side in pixels of the window over which the photographs must agree (odd)")
      ->check(CLI::Range(1, 31))
      ->capture_default_str();
  cmd->add_flag("--detail-high-frequencies", o->high_frequencies_only,
                "Detail pass: add only what a photograph holds above the blur scale (its detail), keeping the "
                "decoded view's own colours below it");
}

}  // namespace lrf::cli
