#!/usr/bin/env bash
# The thread count changes no output: `cnerf encode` on 1, 2 and 3 threads writes the same
# stream and checkpoint, byte for byte, on Lego (360°, rate control, occupancy grids, pruning,
# the grid chosen at export) and on Fern (forward-facing, NDC).
set -euo pipefail
cnerf=$1 data=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }
export OMP_WAIT_POLICY=passive

same() { # SCENE ARGS...: encodes on 1, 2 and 3 threads; the files must agree
  local scene=$1; shift
  for t in 1 2 3; do
    # (a run this short may miss its --size: that exits 1 with the file written)
    "$cnerf" encode "$data/$scene" -o "$work/$scene-$t.cnrf" --threads "$t" --seed 3 "$@" \
      > "$work/$scene-$t.log" 2>&1 || grep -q "(the file is written)" "$work/$scene-$t.log" ||
      fail "$scene on $t threads: $(tail -3 "$work/$scene-$t.log")"
  done
  for t in 2 3; do
    cmp -s "$work/$scene-1.cnrf" "$work/$scene-$t.cnrf" || fail "$scene: the stream on $t threads differs from 1 thread's"
    cmp -s "$work/$scene-1.cnrf.ckpt" "$work/$scene-$t.cnrf.ckpt" || fail "$scene: the checkpoint on $t threads differs from 1 thread's"
  done
  echo "$scene: 1, 2 and 3 threads: $(md5sum < "$work/$scene-1.cnrf" | cut -c1-32) ($(stat -c %s "$work/$scene-1.cnrf") bytes)"
}

# Batches of 7.8 and 7.0 chunks (CN_CHUNK_RAYS 128), so that the threads split them unevenly.
same lego --preset tiny --downscale 8 --batch 1000 --iters 40 --size 30000 --every 100
same fern --preset tiny --downscale 16 --batch 900 --iters 30 --lambda 0.3 --every 100
echo "OK"
