// libFuzzer entry point; LRF_FUZZ_TARGET names the parser and LRF_FUZZ_GROUP its group's parse function
// (run_plain_target or run_tensor_target, see harness.h).
#include <stdexcept>

#include "harness.h"
#include "lrf/core/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string target = LRF_FUZZ_TARGET;
  std::string bytes(reinterpret_cast<const char*>(data), size);
  try {
    if (!lrf::fuzz::LRF_FUZZ_GROUP(target, bytes)) throw std::logic_error("unknown fuzz target " + target);
  } catch (const lrf::Error&) {
    // A clean, reported refusal is the expected outcome for bad input.
  }
  return 0;
}
