// Both groups of fuzz targets behind one entry point: the test suite's replay and the seed writer.
#include <stdexcept>

#include "harness.h"
#include "lrf/core/error.h"

namespace lrf::fuzz {

const std::vector<std::string>& target_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> all = plain_target_names();
    for (const auto& t : tensor_target_names()) all.push_back(t);
    return all;
  }();
  return names;
}

int run_target(const std::string& target, const uint8_t* data, size_t size) {
  std::string bytes(reinterpret_cast<const char*>(data), size);
  try {
    if (!run_plain_target(target, bytes) && !run_tensor_target(target, bytes))
      throw std::logic_error("unknown fuzz target " + target);
  } catch (const Error&) {
    // A clean, reported refusal is the expected outcome for bad input.
  }
  return 0;
}

}  // namespace lrf::fuzz
