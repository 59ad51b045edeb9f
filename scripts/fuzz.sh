#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (ASan + UBSan) and runs each for SECONDS (default 600) on a
# seed corpus the project writes itself. Crashes land in build-fuzz/crashes/<target>/: copy the input to
# tests/fuzz_regressions/<target>/ once fixed, so the normal test suite replays it.
#   usage: scripts/fuzz.sh [SECONDS] [TARGET...]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-600}
shift || true
command -v clang++ >/dev/null || { echo "fuzz: installing clang"; apt-get install -y -qq clang libclang-rt-14-dev; }
# The seed writer is a normal (gcc) build product.
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build --target lrf_fuzz_seeds
CC=clang CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DLRF_FUZZ=ON -DLRF_BUILD_TESTS=OFF -DLRF_BUILD_BENCH=OFF >/dev/null
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(colmap_bin colmap_txt npy correspondences transforms safetensors torch_zip pickle ply
                                     field_config scene_spec)
cmake --build build-fuzz --target "${targets[@]/#/fuzz_}"
rm -rf build-fuzz/seeds && ./build/lrf_fuzz_seeds build-fuzz/seeds
# One thread per fuzzer (libtorch's pools included); process-lifetime allocations inside the
# uninstrumented libtorch are not leaks of ours (see scripts/lsan.supp).
export OMP_NUM_THREADS=1
export LSAN_OPTIONS="suppressions=$PWD/scripts/lsan.supp:print_suppressions=0"
for t in "${targets[@]}"; do
  mkdir -p "build-fuzz/corpus/$t" "build-fuzz/crashes/$t"
  cp -n build-fuzz/seeds/"$t"/* "build-fuzz/corpus/$t/" 2>/dev/null || true
  echo "fuzz: $t for ${seconds}s"
  ./build-fuzz/fuzz_"$t" -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 \
    -artifact_prefix="build-fuzz/crashes/$t/" "build-fuzz/corpus/$t" 2>&1 | tee "build-fuzz/$t.log" | grep -aE "^#[0-9]+[[:space:]]+DONE|stat::|ERROR|SUMMARY" || true
done
