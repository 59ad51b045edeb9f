#pragma once
// What produced an output folder: the command line, the options, the versions of lrf and its libraries.
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace lrf {

// The command line of this process, set once by main().
void set_command_line(int argc, char** argv);
const std::vector<std::string>& command_line();
// {"lrf": ..., "git": ..., "libtorch": ..., "opencv": ..., "build": ...}
nlohmann::json version_info();
// A fact that a layer above core adds to version_info() (the rasterizer its vector width), registered by
// that layer when the program starts, so that core depends on none of them.
void add_version_fact(const std::string& key, std::function<nlohmann::json()> fact);
std::string version_string();
// {"command": [...], "versions": {...}, "time": ISO-8601, "options": options}
nlohmann::json run_record(const nlohmann::json& options);
// Writes pretty JSON atomically.
void write_json_file(const std::string& path, const nlohmann::json& value);
// Parses a JSON file, naming the file in any error.
nlohmann::json read_json_file(const std::string& path);
// Each setting of `wanted` that `recorded` lacks or holds with another value, as " key (recorded vs wanted)"
// ("none" when lacking); empty when every one agrees. For refusing to reuse a result made otherwise.
std::string differing_settings(const nlohmann::json& recorded, const nlohmann::json& wanted);

}  // namespace lrf
