#!/usr/bin/env bash
# Freestanding Cortex-M4 build of the decoder: -std=c99 -ffreestanding -nostdlib, linked with
# a minimal entry point and nothing else. Prints code/data sizes, sizeof(cnerf_decoder) and
# the worst-case stack, and fails if docs/decoder.md states other numbers. BUILD_M4 names the
# build directory (default build-m4; emptied first).
set -euo pipefail
cd "$(dirname "$0")/.."
# From an empty directory: call-graph files of sources that no longer exist would otherwise
# be read as part of the decoder (scripts/stack_usage.py refuses two definitions of one name).
build=${BUILD_M4:-build-m4}
rm -rf "$build"
cmake -S . -B "$build" -DCMAKE_TOOLCHAIN_FILE=cmake/toolchains/arm-none-eabi.cmake \
      -DCMAKE_BUILD_TYPE=MinSizeRel
log=$(mktemp)
trap 'rm -f "$log"' EXIT
cmake --build "$build" | tee "$log"

text=$(awk '/\(TOTALS\)/ {print $1}' "$log")
data=$(awk '/\(TOTALS\)/ {print $2}' "$log")
bss=$(awk '/\(TOTALS\)/ {print $3}' "$log")
dec=$(awk '/^sizeof\(cnerf_decoder\)/ {print $2}' "$log")
open_stack=$(awk '$2 == "cnerf_open" {print $3}' "$log")
stale=0
check() { # what, pattern expected in docs/decoder.md
  if ! grep -qF -- "$2" docs/decoder.md; then
    echo "docs/decoder.md is stale: it should state $1 as measured: '$2'" >&2
    stale=1
  fi
}
check "the decoder's code size" "| **decoder total** | **$text** | **$data** | **$bss** |"
check "sizeof(cnerf_decoder)" "| \`cnerf_decoder\` (caller-owned) | $dec on Cortex-M4"
check "cnerf_open's worst-case stack" "| \`cnerf_open\` | $open_stack |"
exit $stale
