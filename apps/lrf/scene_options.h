#pragma once
// The scene options shared by every subcommand that reads a scene.
#include <CLI/CLI.hpp>

#include "lrf/scene/scene.h"

namespace lrf::cli {

inline void add_scene_options(CLI::App* cmd, SceneOptions* o) {
  cmd->add_option("--images", o->images_dir,
                                 "Image folder inside the scene, e.g. images_8 (default: images, else the "
                                 "least downscaled images_N); intrinsics follow its resolution");
  cmd->add_option("--downscale", o->downscale, "Area-resize the chosen images by this factor (intrinsics scaled)")
      ->capture_default_str();
  cmd->add_option("--test-every", o->test_every,
                  "Test views are those whose index (views sorted by name) is a multiple of N; 0: no test views")
      ->capture_default_str();
  cmd->add_option("--test-list", o->test_list, "File with the test views' image names, one per line");
  cmd->add_option("--train-views", o->train_views,
                  "Few-shot: train on only K views, evenly spaced over the non-test views (as the few-shot "
                  "literature picks LLFF's 3 views); initial points are then triangulated from those K; 0: all")
      ->capture_default_str();
  cmd->add_option("--format", o->format, "Force the scene format instead of detecting it")
      ->check(CLI::IsMember({"colmap", "llff", "nerf"}));
  cmd->add_flag("--crop8", o->crop_to_multiple_of_8, "Centre-crop images to a multiple of 8 pixels");
}

}  // namespace lrf::cli
