#!/usr/bin/env bash
# What keeps a compressed preset small in fog where its float model finds the scene
# (docs/training.md, "The float phase"): the encode of a 2000-iteration run with each of the
# compressed training's differences from the float one removed, or all of them but one, its
# validation PSNR read at iteration 500 (the run is stopped there). Preset small, one
# thread, --max-size 100, seed 1.
#   experiments/float_phase_causes.sh OUT SCENE_DIR
# Writes OUT/float_phase_causes.md. The float phase as long as the run is --float-iters 1999
# (the first 500 iterations are the same as with a phase of 2000).
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: experiments/float_phase_causes.sh OUT SCENE_DIR}
scene=${2:?usage: experiments/float_phase_causes.sh OUT SCENE_DIR}
cnerf=${CNERF:-./build/cnerf}
mkdir -p "$out"
all=(--lambda 0 --coarse-weight 1 --float-iters 1999 --lr-warmup 20 --affine-lr 0 --scale-lr 0)
runs=(
  "rounded from the start (the encode before the float phase)|--size 30000 --float-iters 0"
  "the warm-up alone|--size 30000 --float-iters 0 --lr-warmup 20"
  "unrounded alone|--size 30000 --float-iters 1999 --lr-warmup 0"
  "all differences removed|${all[*]}"
  "all but rounding|--lambda 0 --coarse-weight 1 --float-iters 0 --lr-warmup 20 --affine-lr 0 --scale-lr 0"
  "all but the warm-up|--lambda 0 --coarse-weight 1 --float-iters 1999 --lr-warmup 0 --affine-lr 0 --scale-lr 0"
  "all but the coarse weight (0.1)|--lambda 0 --float-iters 1999 --lr-warmup 20 --affine-lr 0 --scale-lr 0"
  "all but the affine decoders' rates|--lambda 0 --coarse-weight 1 --float-iters 1999 --lr-warmup 20"
  "all but the rate (--size 30000)|--size 30000 --coarse-weight 1 --float-iters 1999 --lr-warmup 20 --affine-lr 0 --scale-lr 0"
)
md=$out/float_phase_causes.md
{
  echo "| run | options | validation PSNR at iteration 500 |"
  echo "|---|---|---|"
} > "$md"
k=0
for r in "${runs[@]}"; do
  k=$((k + 1))
  name=${r%%|*} opts=${r#*|} log=$out/run$k.log
  if ! grep -q '^iter 500/' "$log" 2>/dev/null; then
    # shellcheck disable=SC2086 # opts is a list of options
    stdbuf -oL "$cnerf" encode "$scene" -o "$out/run$k.cnrf" --force --preset small \
      --iters 2000 --max-size 100 --threads 1 --seed 1 --log-every 100 $opts > "$log" 2>&1 &
    pid=$!
    while ! grep -q '^iter 500/' "$log" 2>/dev/null && kill -0 $pid 2>/dev/null; do sleep 2; done
    kill $pid 2>/dev/null || true
    wait $pid 2>/dev/null || true
  fi
  v=$(sed -n 's/^iter 500\/.* val \([0-9.]*\) dB.*/\1/p' "$log")
  echo "| $name | \`$opts\` | ${v:-–} dB |" >> "$md"
done
cat "$md"
