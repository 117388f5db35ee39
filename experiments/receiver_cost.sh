#!/usr/bin/env bash
# Instructions per ray of the firmware decoder (Cortex-M4, -Os, QEMU's counts) on the
# reference stream experiments/data/lego-c070829.cnrf (the README main job's stream at
# commit c070829), for the tiles of docs/decoder.md "Empty stretches of rays cost almost
# nothing": the whole view r_0, two corner tiles, and every ray missing the bounds. Each
# render's MD5 is checked against the host's by scripts/firmware.sh; the whole view's must be
# e8516816eb358986fb227cd2beb4f48e (the same pixels as every earlier decoder).
#
#   experiments/receiver_cost.sh            the markdown rows
# FW_BOARD=an547 measures the Cortex-M55 build instead. The renders use 32 + 32 samples and
# t_stop 2^30 / 4096 (262144, Q30), the default when that stream was made and the setting of
# its MD5; T_STOP_Q30 sets another (the whole view's MD5 is then not the one above).
set -euo pipefail
cd "$(dirname "$0")/.."
d=experiments/data
row() { # label camera tile
  local out
  out=$(FW_TIMEOUT=3000 scripts/firmware.sh "$d/lego-c070829.cnrf" "$d/$2" "$3" 32 32 \
        "${T_STOP_Q30:-262144}" 2>&1) || {
    echo "$out" >&2; exit 1; }
  local ipr evals
  ipr=$(sed -n 's/.*: \([0-9,]*\) instructions per ray.*/\1/p' <<<"$out")
  evals=$(sed -n 's/.*network evaluations per ray: \([0-9.]*\) .*/\1/p' <<<"$out")
  echo "| $1 | \`$3\` | $evals | $ipr |"
}
echo "| tile | camera, tile | evaluations per ray | instructions per ray |"
echo "|---|---|---|---|"
md5=e8516816eb358986fb227cd2beb4f48e
[ "${T_STOP_Q30:-262144}" = 262144 ] || md5=
FW_EXPECT_MD5=$md5 row "whole view r_0" lego-c070829.r_0.cam "0 0 100 100"
row "corner: only empty cells" lego-c070829.r_0.cam "0 0 10 10"
row "bottom left: empty cells beside occupied ones" lego-c070829.r_0.cam "0 90 10 10"
row "turned away: every ray misses the bounds" lego-c070829.away.cam "0 0 100 100"
