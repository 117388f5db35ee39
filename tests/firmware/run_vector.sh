#!/usr/bin/env bash
# ctests firmware_m4*, firmware_m55: a tile of a conformance vector, rendered by the firmware
# under qemu-system-arm, must have the MD5 that vectors/valid/NAME.md5 lists (and the host's).
# The firmware is built in BUILD_DIR, for the board FW_BOARD names (scripts/firmware.sh:
# an386, the Cortex-M4, by default; an547, the Cortex-M55); BUILD_DIR must be the board's own.
#   [FW_BOARD=an386|an547] [FW_FAST=1] run_vector.sh VECTORS_DIR NAME BUILD_DIR [LINE [FLAGS [SCENE]]]
# LINE (1, the first tile, by default) picks the tile line of NAME.md5; FLAGS (0) is
# cnerf_render_opts.flags: with 1 (CNERF_RENDER_NO_SKIP, the occupancy grid ignored) the
# tile's MD5 is checked against the host's render only, as the vector lists none for it.
# SCENE (0) picks the scene of a stream of several: its tiles are NAME.s<SCENE>.md5's.
set -euo pipefail
vectors=$1 name=$2 build=$3 line=${4:-1} flags=${5:-0} scene=${6:-0}
root=$(cd "$(dirname "$0")/../.." && pwd)
sfx=$([ "$scene" = 0 ] && echo "" || echo ".s$scene")
read -r cam x0 y0 w h nc nf ts md5 < <(sed -n "${line}p" "$vectors/valid/$name$sfx.md5")
[ -n "${md5:-}" ] || { echo "run_vector.sh: $name$sfx.md5 has no line $line" >&2; exit 1; }
grep -E "[[:space:]]$cam\$" "$vectors/valid/$name$sfx.cam" > "$build.cam" ||
  { echo "run_vector.sh: camera $cam is not in $name$sfx.cam" >&2; exit 1; }
mkdir -p "$build"
expect=$md5
[ "$flags" = 0 ] || expect=
FW_BOARD=${FW_BOARD:-an386} FW_BUILD_DIR=$build FW_EXPECT_MD5=$expect FW_SCENE=$scene \
  "$root/scripts/firmware.sh" "$vectors/valid/$name.cnrf" "$build.cam" "$x0 $y0 $w $h" "$nc" "$nf" \
  "$ts" "$flags"
# FW_FAST=1 (a workspace of cnerf_workspace_size_fast bytes): the same MD5, and the
# firmware's own count of its work must show no int8 sums, every latent kept as int16.
if [ "${FW_FAST:-0}" = 1 ]; then
  s8=$(sed -n 's/.* s8_macs \([0-9]*\).*/\1/p' "$build/firmware.out" | head -n 1)
  [ "$s8" = 0 ] || { echo "run_vector.sh: FW_FAST=1 but the firmware summed ${s8:-?} int8 MACs" >&2; exit 1; }
  echo "run_vector.sh: every latent as int16 (s8_macs 0)"
fi
