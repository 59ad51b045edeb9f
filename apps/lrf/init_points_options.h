#pragma once
// The options that choose a field's initial points, shared by every subcommand that trains fields from a
// scene (train, compare); the command passes them to every field it builds, so that all start alike.
#include <CLI/CLI.hpp>

#include "lrf/points/initial_points.h"

namespace lrf::cli {

inline void add_init_points_options(CLI::App* cmd, InitPointsOptions* o) {
  cmd->add_option("--init-points", o->mode,
                  "Initial points of the field: auto (the scene's SfM points; without them, points triangulated "
                  "from the training views with the known poses, cached beside the latent cache; random points "
                  "if triangulation fails or keeps fewer than 100), random, triangulate (even when the scene "
                  "has points), or a COLMAP points3D .bin/.txt file")
      ->capture_default_str();
  cmd->add_option("--far-shell", o->shell.points,
                  "Add a shell of this many lattice points around the scene for the far background (sky, distant "
                  "walls), coloured from the training views; only the ones a training view sees are kept (0: none; "
                  "not with random points)")
      ->capture_default_str();
  cmd->add_option("--far-shell-radius", o->shell.radius_factor,
                  "Shell radius as a multiple of the scene's reach (97th percentile of the points' distance from "
                  "their median, or the farthest camera if farther)")
      ->capture_default_str();
}

}  // namespace lrf::cli
