#!/usr/bin/env bash
# Installs every Debian package lrf needs to build, test and benchmark. Idempotent: packages already
# present are skipped by apt, and the package lists are refreshed only when something is missing.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git
  libtorch-dev libdnnl-dev libgloo-dev libopenblas0-openmp libopenblas-dev
  libopencv-dev libeigen3-dev nlohmann-json3-dev libcli11-dev libspdlog-dev libfmt-dev
  libsqlite3-dev libgtest-dev libgmock-dev libbenchmark-dev
  python3-numpy python3-torch
  libcpp-httplib-dev chromium
)
# libcpp-httplib-dev: the HTTP client of the viewer's tests and benchmark; chromium: the viewer's browser test (headless).
# Optional: colmap (SfM tool of the field, used only when a user asks for it); node and npm for the test
# that opens a field's .ply in the npm package @playcanvas/splat-transform (skipped without node; any
# node >= 18 already on the machine is kept rather than replaced by Debian's).
optional=(colmap)
if ! command -v node > /dev/null; then optional+=(nodejs); fi
if ! command -v npm > /dev/null; then optional+=(npm); fi

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi

missing=()
for p in "${packages[@]}" "${optional[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ "${#missing[@]}" -eq 0 ]; then
  echo "install-deps: all packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${packages[@]}"
for p in "${optional[@]}"; do
  "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "$p" || echo "install-deps: optional $p not installed"
done
