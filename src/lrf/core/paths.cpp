#include "lrf/core/paths.h"

#include <filesystem>

#include "lrf/core/error.h"

namespace lrf {

std::string canonical_path(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path c = fs::weakly_canonical(path, ec);
  return ec ? fs::absolute(path).lexically_normal().string() : c.string();
}

bool same_path(const std::string& a, const std::string& b) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec)) {
    const bool same = fs::equivalent(a, b, ec);
    if (!ec) return same;
  }
  return canonical_path(a) == canonical_path(b);
}

void refuse_output_over_input(const std::string& output, const std::string& input, const std::string& input_role) {
  if (same_path(output, input)) {
    fail_usage(output + ": is " + input_role + " (" + input + "), which lrf only reads: write the output elsewhere");
  }
}

}  // namespace lrf
