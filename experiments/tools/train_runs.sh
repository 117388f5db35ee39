#!/usr/bin/env bash
# Float `train` runs on one thread at --max-size 100, one per "NAME|ARGS", into a markdown
# table: validation PSNR, PSNR on the training views, share of the occupancy grid occupied.
# Runs whose log is complete are not run again (experiments/warmup.sh, experiments/fog.sh).
#   train_runs.sh OUT DATASET ITERS TABLE.md "NAME|ARGS" ...
set -euo pipefail
out=$1 data=$2 iters=$3 table=$4
shift 4
cnerf=${CNERF:-./build/cnerf}
mkdir -p "$out"
echo "| run | validation (dB) | training views (dB) | occupied |" > "$table"
echo "|---|---|---|---|" >> "$table"
for r in "$@"; do
  name=${r%%|*} args=${r#*|}
  log=$out/$name.log
  [ -s "$log" ] && grep -q "^validation:" "$log" ||
    $cnerf train "$data" -o "$out/$name.ckpt" --force --iters "$iters" --max-size 100 --threads 1 \
      $args > "$log" 2>&1
  val=$(sed -n 's/^validation: psnr \([0-9.]*\) dB.*, \([0-9.]*\) dB on the training views.*/\1 | \2/p' "$log")
  occ=$(grep -o "occupied [0-9]*%" "$log" | tail -n 1 | cut -d' ' -f2)
  echo "| $name | $val | $occ |" >> "$table"
done
cat "$table"
