#!/usr/bin/env bash
# ctest firmware_m4: the first tile of a conformance vector, rendered by the Cortex-M4
# firmware under qemu-system-arm, must have the MD5 that vectors/valid/NAME.md5 lists (and
# the host's). The firmware is built in BUILD_DIR.
#   run_vector.sh VECTORS_DIR NAME BUILD_DIR
set -euo pipefail
vectors=$1 name=$2 build=$3
root=$(cd "$(dirname "$0")/../.." && pwd)
read -r cam x0 y0 w h nc nf ts md5 < "$vectors/valid/$name.md5"
grep -E "[[:space:]]$cam\$" "$vectors/valid/$name.cam" > "$build.cam" ||
  { echo "run_vector.sh: camera $cam is not in $name.cam" >&2; exit 1; }
mkdir -p "$build"
FW_BUILD_DIR=$build FW_EXPECT_MD5=$md5 \
  "$root/scripts/firmware.sh" "$vectors/valid/$name.cnrf" "$build.cam" "$x0 $y0 $w $h" "$nc" "$nf" "$ts"
