#pragma once
// Subcommands register themselves: each cmd_*.cpp defines a static CommandRegistration that adds its
// CLI11 subcommand(s) and the function that runs each leaf command. main() parses, sets the thread
// count, then runs the leaf the user chose.
#include <functional>
#include <string>

#include <CLI/CLI.hpp>

namespace lrf::cli {

using RunFunction = std::function<int()>;
using SetupFunction = std::function<void(CLI::App& root)>;

// `order` sorts subcommands in `lrf --help` (lower first).
struct CommandRegistration {
  CommandRegistration(int order, SetupFunction setup);
};

// Called from a SetupFunction: `run` executes when `command` is the parsed leaf subcommand.
void on_run(CLI::App* command, RunFunction run);

}  // namespace lrf::cli
