// Apart from field_kind.cpp so that the config parsers link into the fuzzers without the run-record code
// (read_json_file lives with the run records).
#include <filesystem>

#include "lrf/core/run_info.h"
#include "lrf/splat/run/field_kind.h"

namespace fs = std::filesystem;

namespace lrf {

std::optional<FieldKind> field_kind_of(const std::string& run) {
  const std::string path = (fs::path(run) / "config.json").string();
  if (!fs::exists(path)) return std::nullopt;
  return field_kind_of_config(read_json_file(path), path);
}

}  // namespace lrf
