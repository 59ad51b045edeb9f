#pragma once
// Naming a mistyped subcommand: CLI11 reports `lrf trian x` as "A subcommand is required", which hides
// what went wrong; lrf says "unknown command 'trian'" and suggests the closest one.
#include <string>

#include <CLI/CLI.hpp>

namespace lrf::cli {

// The first word of the command line that is neither an option of `root` (nor an option's value) when it
// is not a subcommand of `root`; "" when it is one, or when there is no such word.
std::string unknown_command(CLI::App& root, int argc, char** argv);

// The subcommand of `root` closest to `word` within two edits (insertions, deletions, substitutions or
// swaps of adjacent letters), or "" when none is that close.
std::string closest_command(CLI::App& root, const std::string& word);

}  // namespace lrf::cli
