#!/usr/bin/env bash
# The learning rate's warm-up against the fog that preset small fell into on a phone capture:
#   experiments/warmup.sh OUT DATASET [ITERS] [--max-size N]
# Float `train` runs of ITERS iterations (default 600) on one thread at --max-size 100: small
# at seeds 1 and 2 without warm-up (--lr-warmup 0) and with the default one, small at half
# the learning rate, small with view branches of 16 and 32 units, and tiny; each line of
# OUT/warmup.md gives the validation PSNR (3 held-out views), the PSNR on the training views
# and the share of the occupancy grid found occupied at the end. docs/training.md ("Warm-up")
# ran it on instant-ngp's fox (experiments/scenes.tsv).
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: experiments/warmup.sh OUT DATASET [ITERS]} data=${2:?dataset} iters=${3:-600}
runs=("small-seed1-nowarmup|--preset small --seed 1 --lr-warmup 0"
      "small-seed1-warmup|--preset small --seed 1"
      "small-seed2-nowarmup|--preset small --seed 2 --lr-warmup 0"
      "small-seed2-warmup|--preset small --seed 2"
      "small-seed1-lr2.5e-3-nowarmup|--preset small --seed 1 --lr 2.5e-3 --lr-warmup 0"
      "small-seed1-view16-nowarmup|--preset small --seed 1 --view-width 16 --lr-warmup 0"
      "small-seed1-view32-nowarmup|--preset small --seed 1 --view-width 32 --lr-warmup 0"
      "tiny-seed1-warmup|--preset tiny --seed 1")
experiments/tools/train_runs.sh "$out" "$data" "$iters" "$out/warmup.md" "${runs[@]}"
