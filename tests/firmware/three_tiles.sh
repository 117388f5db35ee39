#!/usr/bin/env bash
# ctest firmware_m4_tiles: the README main job's stream as committed
# (experiments/data/lego-c070829.cnrf) on three kinds of tile, rendered by the Cortex-M4
# firmware under qemu-system-arm, each with the host's MD5 (scripts/firmware.sh checks it),
# and the instructions per ray of each printed: a tile that crosses the object, one whose
# rays miss the bounds (a camera turned away), and one whose rays cross only empty cells.
# The counts are printed, not checked: docs/decoder.md states them.
#   three_tiles.sh BUILD_DIR
set -euo pipefail
build=$1
root=$(cd "$(dirname "$0")/../.." && pwd)
d=$root/experiments/data
tile() { # label camera tile
  local out
  out=$(FW_BOARD=an386 FW_BUILD_DIR=$build "$root/scripts/firmware.sh" "$d/lego-c070829.cnrf" \
        "$d/$2" "$3" 2>&1) || { echo "$out"; echo "FAIL: $1"; exit 1; }
  grep -E "^(firmware|host) +md5" <<<"$out"
  printf '%s (%s): %s\n' "$1" "$3" \
    "$(sed -n 's/.*: \([0-9,]*\) instructions per ray.*/\1 instructions per ray/p' <<<"$out")"
}
tile "crosses the object" lego-c070829.r_0.cam "45 45 6 6"
tile "misses the bounds" lego-c070829.away.cam "0 0 20 20"
tile "crosses only empty cells" lego-c070829.r_0.cam "0 0 10 10"
