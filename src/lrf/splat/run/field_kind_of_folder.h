#pragma once
// The kind of the field a folder holds, from its config.json. Apart from field_kind.h so that the config
// parsers link into the fuzzers without the run-record code (read_json_file lives with the run records).
#include <optional>
#include <string>

#include "lrf/splat/run/field_kind.h"

namespace lrf {

// The kind of the field in folder `run`: nullopt when it has no config.json (not a run, or not one yet).
// Throws lrf::Error naming the file when config.json is unreadable or names an unknown kind.
std::optional<FieldKind> field_kind_of(const std::string& run);

}  // namespace lrf
