#pragma once
// One entry point per parser for the fuzzers (fuzz/fuzz_main.cpp) and for the regression replay in the
// test suite (tests/test_fuzz_replay.cpp): parse the bytes, accept a clean lrf::Error, crash on anything
// else (a sanitizer report, an uncaught exception, a hang).
//
// The targets come in two groups so that each fuzzer links only the parsers it needs: harness.cpp
// (file formats without tensors: COLMAP, .npy, correspondences, transforms.json) and
// harness_tensors.cpp (formats that yield tensors, linked with libtorch: safetensors, the PyTorch zip and
// its pickle, .ply fields, a run's config.json). harness_all.cpp joins them for the test suite.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace lrf::fuzz {

// Every target, both groups.
const std::vector<std::string>& target_names();
// Returns 0. Throws only on unexpected exceptions (which the fuzzer reports as crashes).
int run_target(const std::string& target, const uint8_t* data, size_t size);

// The groups: the names they hold, and a parse that returns false for a name outside the group.
// lrf::Error propagates (the callers treat it as the expected refusal).
const std::vector<std::string>& plain_target_names();
bool run_plain_target(const std::string& target, const std::string& bytes);
const std::vector<std::string>& tensor_target_names();
bool run_tensor_target(const std::string& target, const std::string& bytes);

}  // namespace lrf::fuzz
