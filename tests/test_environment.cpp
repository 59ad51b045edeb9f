// The suite runs the autoencoders in fp32 whatever the CPU, so that its reference comparisons (PyTorch's
// outputs, exact resumes, loss thresholds) mean the same on every machine; the bf16 paths are tested by
// the tests that ask for bf16 (test_precision.cpp, the Stage I/III tests parametrised by precision).
// `LRF_PRECISION=bf16 ctest` runs the whole suite in bf16 instead. The `lrf` processes the CLI tests
// start inherit the choice.
#include <cstdlib>

namespace {

const bool kFp32Unless = [] {
  ::setenv("LRF_PRECISION", "fp32", /*overwrite=*/0);
  return true;
}();

}  // namespace
