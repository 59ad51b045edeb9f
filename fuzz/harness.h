#pragma once
// One entry point per parser for the fuzzers (fuzz/fuzz_main.cpp) and for the regression replay in the
// test suite (tests/test_fuzz_replay.cpp): parse the bytes, accept a clean lrf::Error, crash on anything
// else (a sanitizer report, an uncaught exception, a hang).
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace lrf::fuzz {

const std::vector<std::string>& target_names();
// Returns 0. Throws only on unexpected exceptions (which the fuzzer reports as crashes).
int run_target(const std::string& target, const uint8_t* data, size_t size);

}  // namespace lrf::fuzz
