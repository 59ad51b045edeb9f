#include "preset_option.h"

#include <algorithm>

#include "lrf/core/error.h"

namespace lrf::cli {

CLI::Option* add_preset_option(CLI::App* cmd, const PresetTable& table, std::string* name) {
  *name = kDefaultPreset;
  return cmd->add_option("--preset", *name, preset_help(table))->capture_default_str();
}

void apply_preset(CLI::App* cmd, const PresetTable& table, const std::string& name, const std::string& space) {
  const Preset& preset = find_preset(table, name);
  for (const auto& setting : preset.settings) {
    if (!space.empty() && !setting.spaces.empty() &&
        std::find(setting.spaces.begin(), setting.spaces.end(), space) == setting.spaces.end())
      continue;
    CLI::Option* option = cmd->get_option(setting.option);  // throws for a table naming no option: a bug
    if (option->count() > 0) continue;  // given on the command line: the user's value wins
    option->add_result(setting.value);
    option->run_callback();
  }
}

}  // namespace lrf::cli
