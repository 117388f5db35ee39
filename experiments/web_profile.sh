#!/usr/bin/env bash
# Where the WebAssembly decoder's time goes: the package renders a stream's first camera in
# Node with one worker, under V8's sampling profiler, and the functions' shares of the
# worker's time are printed (self time, the largest first). The module is build/web's, linked
# again from its objects with its names kept (wasm-ld without --strip-all: the same code).
#   experiments/web_profile.sh STREAM CAMFILE [RUNS] [TOP]
# CAMFILE: a `cnerf render --save-cameras` file (its first line is rendered); RUNS renders
# (default 6) after one untimed; TOP functions printed (default 10). Needs build/web (or
# CNERF_WEB=DIR: another build's web directory, with its obj/), wasm-ld and node.
set -euo pipefail
cd "$(dirname "$0")/.."
stream=${1:?usage: experiments/web_profile.sh STREAM CAMFILE [RUNS] [TOP]}
cams=${2:?usage: experiments/web_profile.sh STREAM CAMFILE [RUNS] [TOP]}
runs=${3:-6} top=${4:-10}
web=${CNERF_WEB:-build/web}
[ -d "$web/obj" ] || { echo "web_profile.sh: $web/obj is missing (build the tree with clang and wasm-ld)" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"${WASM_LD:-wasm-ld}" --no-entry --export=__heap_base -z stack-size=262144 "$web"/obj/*.o \
  -o "$tmp/named.wasm"
node --cpu-prof --cpu-prof-dir="$tmp/prof" experiments/web_profile.mjs render "$web" \
  "$tmp/named.wasm" "$stream" "$cams" "$runs"
node experiments/web_profile.mjs report "$tmp/prof" "$top"
