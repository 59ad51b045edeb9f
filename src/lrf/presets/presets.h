#pragma once
// Named bundles of option defaults (--preset quick|default|paper) for the commands whose defaults cost hours
// on a CPU: train, compare and pipeline. One table per command is both what --preset applies and what
// --help prints, so the two cannot drift. A preset only supplies defaults: an option given on the command
// line wins over it.
#include <string>
#include <vector>

namespace lrf {

struct PresetSetting {
  std::string option;  // the command's long option, e.g. "--steps"
  std::string value;   // as it would be typed after the option
  std::string why;     // one short clause for --help
  // The `lrf train --space` values the setting applies to ("" = all): a setting that would be refused with
  // some space (an SH degree for a NeRF) is left out there rather than made an error.
  std::vector<std::string> spaces;
};

struct Preset {
  std::string name;     // quick, default or paper
  std::string summary;  // what the preset is for, one line
  std::vector<PresetSetting> settings;  // default: none (today's defaults exactly)
};

using PresetTable = std::vector<Preset>;

constexpr const char* kDefaultPreset = "default";

const PresetTable& train_presets();
const PresetTable& compare_presets();
const PresetTable& pipeline_presets();

// The preset called `name`; throws lrf::UsageError naming the valid ones when there is none.
const Preset& find_preset(const PresetTable& table, const std::string& name);

// The names, "quick, default, paper".
std::string preset_names(const PresetTable& table);

// The --preset help text: every preset with what it sets and why.
std::string preset_help(const PresetTable& table);

}  // namespace lrf
