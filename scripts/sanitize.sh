#!/usr/bin/env bash
# Builds lrf with AddressSanitizer + UndefinedBehaviorSanitizer (build-asan/) and runs the whole test
# suite under them, including the fuzz corpus replay. Any sanitizer report fails the run.
#   usage: scripts/sanitize.sh [ctest arguments...]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DLRF_SANITIZE=ON -DLRF_BUILD_BENCH=OFF
cmake --build build-asan -j "$(nproc)"
# libtorch and OpenMP are not instrumented and keep process-lifetime allocations that LeakSanitizer
# would list at exit; suppress only those libraries, never lrf's own frames.
export LSAN_OPTIONS="suppressions=$PWD/scripts/lsan.supp:print_suppressions=0"
export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1:abort_on_error=0"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
cd build-asan
ctest --output-on-failure -j "$(nproc)" "$@"
