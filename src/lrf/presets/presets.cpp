#include "lrf/presets/presets.h"

#include "lrf/core/error.h"

namespace lrf {
namespace {

// The quick presets aim at a few minutes on 2 cores for a scene like fern (docs/commands.md#presets says what
// was measured, and what still has to be). The paper presets take only what the paper states: 30000 steps for every Gaussian field (3DGS's
// schedule, kept by the paper's Stage II), SH degree 3 for latent fields (its code's), 512-pixel Stage I crops.
const std::string kQuickSummary = "a first look in a few minutes on a 2-core CPU";
const std::string kDefaultSummary = "today's defaults, unchanged (the same as no --preset)";
const std::string kPaperSummary = "the paper's settings where lrf has them (hours on a CPU)";

}  // namespace

const PresetTable& train_presets() {
  static const PresetTable table = {
      {"quick", kQuickSummary,
       {{"--steps", "1500", "a twentieth of the full schedule, densification compressed to match", {}},
        {"--downscale", "2", "half the chosen images' width and height: fern's images_4 at images_8's size", {}}}},
      {kDefaultPreset, kDefaultSummary, {}},
      {"paper", kPaperSummary,
       {{"--steps", "30000", "3DGS's and the paper's Stage II schedule", {"rgb", "latent"}},
        {"--sh-degree", "3", "the paper code's SH degree for latent fields", {"rgb", "latent"}}}},
  };
  return table;
}

const PresetTable& compare_presets() {
  static const PresetTable table = {
      {"quick", kQuickSummary,
       {{"--steps", "1000", "steps of every Gaussian field", {}},
        {"--nerf-steps", "1000", "steps of latent-nerf, when asked for", {}},
        {"--refine-steps", "200", "steps of the latent-refined row", {}}}},
      {kDefaultPreset, kDefaultSummary, {}},
      {"paper", kPaperSummary,
       {{"--steps", "30000", "3DGS's and the paper's Stage II schedule for every Gaussian field", {}},
        {"--latent-sh-degree", "3", "the paper code's SH degree for latent fields", {}}}},
  };
  return table;
}

const PresetTable& pipeline_presets() {
  static const PresetTable table = {
      {"quick", kQuickSummary,
       {{"--max-side", "320", "every scene at most 320 pixels wide or high", {}},
        {"--field-steps", "1000", "steps of every latent field and RGB baseline", {}},
        {"--stage1-steps", "40", "Stage I steps", {}},
        {"--stage3-steps", "50", "Stage III steps", {}},
        {"--refine-steps", "200", "steps of the +refine rows", {}}}},
      {kDefaultPreset, kDefaultSummary, {}},
      {"paper", kPaperSummary,
       {{"--field-steps", "30000", "3DGS's and the paper's Stage II schedule for every field", {}},
        {"--stage1-crop", "512", "the paper's 512x512 Stage I crops", {}},
        {"--stage3-weight-roundtrip", "0", "the paper's Stage III loss (no round-trip term)", {}}}},
  };
  return table;
}

const Preset& find_preset(const PresetTable& table, const std::string& name) {
  for (const auto& preset : table)
    if (preset.name == name) return preset;
  fail_usage("--preset must be one of " + preset_names(table) + ", got '" + name + "'");
}

std::string preset_names(const PresetTable& table) {
  std::string names;
  for (const auto& preset : table) names += (names.empty() ? "" : ", ") + preset.name;
  return names;
}

std::string preset_help(const PresetTable& table) {
  std::string text = "Defaults for a kind of run; options given on the command line win over them, and the run's "
                     "config.json records the preset. Training prints the time it expects after its first steps.";
  for (const auto& preset : table) {
    text += "\n  " + preset.name + ": " + preset.summary;
    for (const auto& s : preset.settings) {
      text += "\n    " + s.option + " " + s.value + "  (" + s.why;
      if (!s.spaces.empty()) {
        std::string spaces;
        for (const auto& space : s.spaces) spaces += (spaces.empty() ? "" : ", ") + space;
        text += "; --space " + spaces + " only";
      }
      text += ")";
    }
  }
  return text;
}

}  // namespace lrf
