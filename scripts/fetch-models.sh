#!/usr/bin/env bash
# Downloads public tiny-autoencoder weights (github.com/madebyollin/taesd, MIT licence) into
# ./models/<name>/, the folder `lrf --autoencoder <name>` searches first after $LRF_MODELS.
#
#   scripts/fetch-models.sh            # taef2 and taesd
#   scripts/fetch-models.sh taef1 taesd3
#   MODELS_DIR=/data/models scripts/fetch-models.sh taef2
#
# Known names: taef2 (FLUX.2, 32 ch), taef1 (FLUX.1, 16 ch), taesd3 (SD3, 16 ch), taesdxl (SDXL, 4 ch),
# taesd (SD 1.x/2.x, 4 ch). Files already present are kept. Without network access the script stops
# with an error and changes nothing (downloads go to a temporary file first).
set -euo pipefail

base_url="${TAESD_BASE_URL:-https://github.com/madebyollin/taesd/raw/main}"
models_dir="${MODELS_DIR:-models}"
known=(taef2 taef1 taesd3 taesdxl taesd)

if [ "$#" -eq 0 ]; then set -- taef2 taesd; fi

if command -v curl > /dev/null; then
  fetch() { curl --fail --location --silent --show-error --connect-timeout 15 --max-time 600 -o "$2" "$1"; }
elif command -v wget > /dev/null; then
  fetch() { wget --quiet --timeout=15 -O "$2" "$1"; }
else
  echo "fetch-models: neither curl nor wget is installed (apt-get install curl)" >&2
  exit 1
fi

for name in "$@"; do
  ok=0
  for k in "${known[@]}"; do [ "$k" = "$name" ] && ok=1; done
  if [ "$ok" -ne 1 ]; then
    echo "fetch-models: unknown model '$name' (known: ${known[*]})" >&2
    exit 2
  fi
done

for name in "$@"; do
  mkdir -p "$models_dir/$name"
  for half in encoder decoder; do
    file="${name}_${half}.pth"
    dest="$models_dir/$name/$file"
    if [ -s "$dest" ]; then
      echo "fetch-models: $dest already present"
      continue
    fi
    tmp="$(mktemp "$dest.XXXXXX.tmp")"
    trap 'rm -f "$tmp"' EXIT
    echo "fetch-models: downloading $base_url/$file"
    if ! fetch "$base_url/$file" "$tmp"; then
      rm -f "$tmp"
      rmdir "$models_dir/$name" "$models_dir" 2> /dev/null || true
      echo "fetch-models: could not download $base_url/$file (no network access?). Copy the weights" \
           "into $models_dir/$name/ by hand, or point LRF_MODELS at a folder that has them." >&2
      exit 1
    fi
    # A PyTorch checkpoint is a zip archive; an HTML error page is not.
    if [ "$(head -c 2 "$tmp")" != "PK" ]; then
      rm -f "$tmp"
      echo "fetch-models: $base_url/$file is not a PyTorch checkpoint (got an error page?)" >&2
      exit 1
    fi
    mv "$tmp" "$dest"
    trap - EXIT
  done
  echo "fetch-models: $name ready in $models_dir/$name"
done
