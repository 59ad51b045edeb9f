#pragma once
// --scene DIR for the commands that reopen a trained run (eval, render, serve, refine): the scene's folder
// when it is no longer where the run's config.json recorded it.
#include <string>

#include <CLI/CLI.hpp>

#include "lrf/scene/run_scene_location.h"

namespace lrf::cli {

inline void add_scene_override_option(CLI::App* cmd) {
  cmd->add_option_function<std::string>(
      "--scene", [](const std::string& dir) { set_scene_override(dir); },
      "The scene the run was trained on, when it moved: read it from this folder instead of the one config.json "
      "records (it must have as many training and test views)");
}

}  // namespace lrf::cli
