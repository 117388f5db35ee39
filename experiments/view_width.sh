#!/usr/bin/env bash
# Preset small's view branch: its default width (half the trunk's, 64 units) against narrower ones,
# float `train` runs on one thread at --max-size 100, seed 1, scored on the scene's test views
# (docs/training.md, "Warm-up"; the fog of docs/results.md, "Every scene a user brings"):
#   experiments/view_width.sh OUT DATASET [ITERS] [WIDTHS]
# ITERS defaults to 2000 (the suite's length), WIDTHS to "64 32 16" (the widths docs/training.md reports). OUT/view_width.md gets the
# table. Runs whose log is complete are not run again.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: experiments/view_width.sh OUT DATASET [ITERS] [WIDTHS]} data=${2:?dataset}
iters=${3:-2000} widths=${4:-64 32 16}
runs=()
for w in $widths; do runs+=("small-view$w|--preset small --seed 1 --view-width $w"); done
TEST=1 experiments/tools/train_runs.sh "$out" "$data" "$iters" "$out/view_width.md" "${runs[@]}"
