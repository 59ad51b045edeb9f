#pragma once
// --preset on a command: the option, its help generated from the command's preset table, and the step that
// gives the preset's values to the options the user left out.
#include <string>

#include <CLI/CLI.hpp>

#include "lrf/presets/presets.h"

namespace lrf::cli {

// Adds --preset NAME (stored in *name, "default" when not given) with the table's help text.
CLI::Option* add_preset_option(CLI::App* cmd, const PresetTable& table, std::string* name);

// Checks `name` against the table (a usage error naming the valid presets otherwise), then gives each of
// its settings to the option of `cmd` that the command line did not set, as if typed, so that the option's
// own checks and callbacks run. `space` (lrf train's --space) skips settings meant for other spaces.
void apply_preset(CLI::App* cmd, const PresetTable& table, const std::string& name, const std::string& space = "");

}  // namespace lrf::cli
