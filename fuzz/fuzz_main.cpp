// libFuzzer entry point; LRF_FUZZ_TARGET names the parser (see harness.cpp).
#include "harness.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return lrf::fuzz::run_target(LRF_FUZZ_TARGET, data, size);
}
