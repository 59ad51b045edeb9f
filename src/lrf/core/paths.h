#pragma once
// One spelling of a path for records and comparisons: two runs name the same folder alike however it was
// given (relative, through symlinks, with "." or "..").
#include <string>

namespace lrf {

// The canonical form of `path` (symlinks resolved as far as it exists); the absolute, normalised path when
// that cannot be computed.
std::string canonical_path(const std::string& path);

// Whether `a` and `b` name the same file or folder, however each is spelled (relative, through symlinks,
// with "." or ".."), hard links to one file included. Paths that do not exist compare by spelling.
bool same_path(const std::string& a, const std::string& b);

// Throws lrf::UsageError naming `output` when it is the same file or folder as `input`: lrf never writes over
// what it reads. `input_role` names the input in the message ("the input image", "the scene folder").
void refuse_output_over_input(const std::string& output, const std::string& input, const std::string& input_role);

}  // namespace lrf
