#!/usr/bin/env bash
# Sets up (apt packages), builds (Release, Ninja) and runs the whole test suite. The README's test command.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build -j "$(nproc)"
# The npm tool one test uses (from the npm registry, into build/npm-tools); without node the test skips.
if command -v node > /dev/null && command -v npm > /dev/null; then
  bash scripts/install-npm-tools.sh build/npm-tools || echo "test: npm tools not installed; the splat-transform test will try again"
fi
cd build
ctest --output-on-failure -j "$(nproc)" "$@"
