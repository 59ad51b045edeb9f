#include "lrf/splat/run/field_kind_of_folder.h"

#include <filesystem>

#include "lrf/core/run_info.h"

namespace fs = std::filesystem;

namespace lrf {

std::optional<FieldKind> field_kind_of(const std::string& run) {
  const std::string path = (fs::path(run) / "config.json").string();
  if (!fs::exists(path)) return std::nullopt;
  return field_kind_of_config(read_json_file(path), path);
}

}  // namespace lrf
