#!/usr/bin/env bash
# A device of level 1 (docs/bitstream.md, levl): the firmware of a core (FW_CORE, as
# scripts/firmware.sh takes it; m4 by default) with the decoder
# built with CNERF_MAX_LEVEL=1 and its workspace and scratch the level's
# (CNERF_LEVEL_WORKSPACE(1), CNERF_LEVEL_SCRATCH(1)), rendering a 16x16 tile of the README
# main job's reference stream re-coded at level 1 (cnerf recode) with the host's MD5, in at
# most 96,000 bytes of RAM in all, the stack's worst case included: a 128 KB part with 32 KB
# left for the application.
#   level.sh CNERF OUT_DIR
set -euo pipefail
cnerf=$1 out=$2
root=$(cd "$(dirname "$0")/../.." && pwd)
mkdir -p "$out"
"$cnerf" recode "$root/experiments/data/lego-c070829.cnrf" -o "$out/l1.cnrf" --level 1 > /dev/null
core=${FW_CORE:-m4}
log=$(FW_CORE=$core FW_BOARD= FW_LEVEL=1 FW_WORK=0 FW_BUILD_DIR="$out/fw" \
      "$root/scripts/firmware.sh" "$out/l1.cnrf" "$root/experiments/data/lego-c070829.r_0.cam" \
      "40 40 16 16" 32 32 262144 2>&1) || { echo "$log"; exit 1; }
echo "$log" | grep -E "^(RAM|flash|firmware.sh: OK)"
ram=$(sed -n "s/^RAM needed with the stack's worst case instead of the reservation: \([0-9,]*\) bytes.*/\1/p" <<<"$log" | tr -d ,)
[ -n "$ram" ] || { echo "FAIL: no RAM figure in the firmware's report" >&2; exit 1; }
grep -q "workspace 73,728" <<<"$log" || { echo "FAIL: the workspace is not level 1's" >&2; exit 1; }
if [ "$ram" -gt 96000 ]; then
  echo "FAIL: $ram bytes of RAM, over the 96,000 of level 1" >&2
  exit 1
fi
echo "level 1 on FW_CORE=$core: $ram bytes of RAM in all"
