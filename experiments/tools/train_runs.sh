#!/usr/bin/env bash
# Float `train` runs on one thread at --max-size 100, one per "NAME|ARGS", into a markdown
# table: validation PSNR, PSNR on the training views, share of the occupancy grid occupied,
# and with TEST=1 the PSNR on the dataset's test views (cnerf eval, at the same size). Runs
# whose log is complete are not run again (experiments/warmup.sh, fog.sh, view_width.sh).
#   [TEST=1] train_runs.sh OUT DATASET ITERS TABLE.md "NAME|ARGS" ...
set -euo pipefail
out=$1 data=$2 iters=$3 table=$4
shift 4
cnerf=${CNERF:-./build/cnerf}
mkdir -p "$out"
test=${TEST:-0}
if [ "$test" = 1 ]; then
  echo "| run | test views (dB) | validation (dB) | training views (dB) | occupied |" > "$table"
  echo "|---|---|---|---|---|" >> "$table"
else
  echo "| run | validation (dB) | training views (dB) | occupied |" > "$table"
  echo "|---|---|---|---|" >> "$table"
fi
for r in "$@"; do
  name=${r%%|*} args=${r#*|}
  log=$out/$name.log
  [ -s "$log" ] && grep -q "^validation:" "$log" ||
    $cnerf train "$data" -o "$out/$name.ckpt" --force --iters "$iters" --max-size 100 --threads 1 \
      $args > "$log" 2>&1
  val=$(sed -n 's/^validation: psnr \([0-9.]*\) dB.*, \([0-9.]*\) dB on the training views.*/\1 | \2/p' "$log")
  occ=$(grep -o "occupied [0-9]*%" "$log" | tail -n 1 | cut -d' ' -f2)
  if [ "$test" = 1 ]; then
    [ -s "$out/$name.eval" ] && grep -q "^mean over" "$out/$name.eval" ||
      $cnerf eval "$out/$name.ckpt" "$data" --max-size 100 > "$out/$name.eval" 2>&1
    tst=$(sed -n 's/^mean over [0-9]* test views.*: psnr \([0-9.]*\) dB.*/\1/p' "$out/$name.eval")
    echo "| $name | $tst | $val | $occ |" >> "$table"
  else
    echo "| $name | $val | $occ |" >> "$table"
  fi
done
cat "$table"
