#!/usr/bin/env bash
# ctests cost_model_m4, cost_model_m55: the cost model (platform/host/cost_model.c) against
# QEMU's instruction count on the first tile of every valid conformance vector, rendered by
# the firmware of the board FW_BOARD names (scripts/firmware.sh): the host's count of the
# core's work (cnerf_open_as) must be the firmware's, and the model within TOLERANCE of QEMU.
#   [FW_BOARD=an386|an547] cost_model.sh BUILD_DIR TOLERANCE
set -euo pipefail
build=$1 tol=$2
root=$(cd "$(dirname "$0")/../.." && pwd)
vectors=$root/vectors/valid
fails=0 count=0
for md5 in "$vectors"/*.md5; do
  name=$(basename "$md5" .md5)
  case $name in *.s[0-9]*) continue ;; esac
  read -r cam x0 y0 w h nc nf ts _ < <(head -n 1 "$md5")
  grep -E "[[:space:]]$cam\$" "$vectors/$name.cam" > "$build.cam"
  count=$((count + 1))
  if out=$(FW_BUILD_DIR=$build FW_TIMEOUT=3000 FW_COST_TOLERANCE=$tol "$root/scripts/firmware.sh" \
             "$vectors/$name.cnrf" "$build.cam" "$x0 $y0 $w $h" "$nc" "$nf" "$ts" < /dev/null 2>&1)
  then
    echo "$name: $(sed -n 's/^  cost model: //p' <<<"$out")"
  else
    echo "$out" | tail -n 5
    echo "FAIL: $name"
    fails=$((fails + 1))
  fi
done
echo "$((count - fails)) of $count vectors within $tol of QEMU's count"
[ "$fails" = 0 ]
