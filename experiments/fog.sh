#!/usr/bin/env bash
# Preset small's fog (the whole occupancy grid filled with density, the training views
# themselves not fitted) on a capture where tiny learns the scene: the remedies, one at a
# time, with the default warm-up (docs/training.md, "Warm-up"; docs/results.md, "Every scene a
# user brings"):
#   experiments/fog.sh OUT DATASET [ITERS]
# Float `train` runs of ITERS iterations (default 600) on one thread at --max-size 100: small
# at seeds 1 and 2, small at seed 1 with a warm-up of 100 iterations, with a constant
# background, with a view branch of 16 units and at half the learning rate, and tiny; each
# line of OUT/fog.md gives the validation PSNR (the held-out views), the PSNR on the
# training views and the share of the occupancy grid found occupied at the end. Runs whose
# log is complete are not run again.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: experiments/fog.sh OUT DATASET [ITERS]} data=${2:?dataset} iters=${3:-600}
runs=("small-seed1|--preset small --seed 1"
      "small-seed2|--preset small --seed 2"
      "small-seed1-warmup100|--preset small --seed 1 --lr-warmup 100"
      "small-seed1-bgconst|--preset small --seed 1 --background constant"
      "small-seed1-view16|--preset small --seed 1 --view-width 16"
      "small-seed1-lr2.5e-3|--preset small --seed 1 --lr 2.5e-3"
      "tiny-seed1|--preset tiny --seed 1")
experiments/tools/train_runs.sh "$out" "$data" "$iters" "$out/fog.md" "${runs[@]}"
