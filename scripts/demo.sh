#!/usr/bin/env bash
# Sets up (apt packages), builds, and runs lrf's built-in demo. The README's first command.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build -j "$(nproc)" --target lrf
./build/lrf demo "$@"
