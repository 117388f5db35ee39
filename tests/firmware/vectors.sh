#!/usr/bin/env bash
# ctests firmware_vectors_m7, _m33, _m0plus, cost_model_m4, _m55: the first tile of every
# valid conformance vector (every scene of a stream of several), rendered by the firmware of
# the core FW_CORE names (scripts/firmware.sh) under qemu-system-arm, must have the MD5 the
# vector lists. With TOLERANCE (cost_model_*), the cost model (platform/host/cost_model.c)
# must also be within it of QEMU's count, and the host's count of the core's work
# (cnerf_open_as) the firmware's.
#   FW_CORE=m7|m33|m0plus|m4|m55 vectors.sh BUILD_DIR [TOLERANCE]
set -euo pipefail
build=$1 tol=${2:-}
root=$(cd "$(dirname "$0")/../.." && pwd)
vectors=$root/vectors/valid
fails=0 count=0
for md5 in "$vectors"/*.md5; do
  name=$(basename "$md5" .md5)
  scene=0 stream=$name
  case $name in *.s[0-9]*) scene=${name##*.s} stream=${name%.s*} ;; esac
  read -r cam x0 y0 w h nc nf ts want < <(head -n 1 "$md5")
  grep -E "[[:space:]]$cam\$" "$vectors/$name.cam" > "$build.cam"
  count=$((count + 1))
  if out=$(FW_BUILD_DIR=$build FW_TIMEOUT=3000 FW_EXPECT_MD5=$want FW_SCENE=$scene \
             FW_COST_TOLERANCE=$tol \
             "$root/scripts/firmware.sh" "$vectors/$stream.cnrf" "$build.cam" "$x0 $y0 $w $h" \
             "$nc" "$nf" "$ts" < /dev/null 2>&1)
  then
    echo "$name: $want, $(sed -n 's/.*: \([0-9,]*\) instructions per ray.*/\1/p' <<<"$out") instructions per ray$(sed -n 's/^  cost model: /; cost model: /p' <<<"$out")"
  else
    echo "$out" | tail -n 5
    echo "FAIL: $name"
    fails=$((fails + 1))
  fi
done
echo "${FW_CORE:-${FW_BOARD:-m4}}: $((count - fails)) of $count vectors' first tiles have their MD5${tol:+, the cost model within $tol of the count by QEMU}"
[ "$fails" = 0 ]
