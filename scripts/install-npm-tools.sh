#!/usr/bin/env bash
# Installs the npm packages the tests use into DIR (default: build/npm-tools) from the npm registry:
#   @playcanvas/splat-transform, a converter of the 3DGS ecosystem that reads the Inria .ply lrf writes.
# Needs node and npm; idempotent (an installed, matching version is kept). Never commit DIR.
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${1:-build/npm-tools}
# 2.7.1: the newest release that still runs on Node 18 (Debian 12's nodejs); 3.x needs Node 22.
package=@playcanvas/splat-transform
version=2.7.1

if ! command -v node > /dev/null || ! command -v npm > /dev/null; then
  echo "install-npm-tools: node and npm are needed (Debian: apt-get install nodejs npm)" >&2
  exit 1
fi
installed="$dir/node_modules/$package/package.json"
if [ -f "$installed" ] && grep -q "\"version\": \"$version\"" "$installed"; then
  echo "install-npm-tools: $package@$version present in $dir"
  exit 0
fi
mkdir -p "$dir"
# --ignore-scripts: nothing from the registry runs at install time (the GPU module's postinstall is not
# needed for reading and writing files on the CPU).
npm install --prefix "$dir" --no-audit --no-fund --no-save --ignore-scripts --loglevel=error "$package@$version"
echo "install-npm-tools: installed $package@$version in $dir"
