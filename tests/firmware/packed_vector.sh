#!/usr/bin/env bash
# The conformance vectors' packed images on their cores (vectors/packed/): for the M4 (dsp),
# the M55 (mve) and the M0+ (c), cnerf pack must write vector 034's image byte for byte as
# vectors/packed/ holds it, and the firmware, embedding that image in flash and opening it in
# place (FW_PACK), must render the vector's first tile with the MD5 the vector lists.
#   packed_vector.sh CNERF OUT_DIR
set -euo pipefail
cnerf=$1 out=$2
root=$(cd "$(dirname "$0")/../.." && pwd)
v=034-level-1-small
mkdir -p "$out"
for t in "m4 cortex-m4 dsp" "m55 cortex-m55 mve" "m0plus cortex-m0plus c"; do
  read -r core target set <<< "$t"
  "$cnerf" pack "$root/vectors/valid/$v.cnrf" --target "$target" -o "$out/$v.$set.img" > /dev/null
  cmp -s "$out/$v.$set.img" "$root/vectors/packed/$v.$set.img" ||
    { echo "FAIL: cnerf pack --target $target no longer writes vectors/packed/$v.$set.img" >&2; exit 1; }
  log=$(FW_CORE=$core FW_PACK=$set FW_WORK=0 bash "$root/tests/firmware/run_vector.sh" \
        "$root/vectors" "$v" "$out/fw_$core" 1 2>&1) || { echo "$log"; exit 1; }
  grep -q "^firmware.sh: OK" <<< "$log" || { echo "$log"; exit 1; }
  echo "$core: vector $v's first tile from its $set image in flash, the vector's MD5"
done
