#pragma once
// One spelling of a path for records and comparisons: two runs name the same folder alike however it was
// given (relative, through symlinks, with "." or "..").
#include <string>

namespace lrf {

// The canonical form of `path` (symlinks resolved as far as it exists); the absolute, normalised path when
// that cannot be computed.
std::string canonical_path(const std::string& path);

}  // namespace lrf
