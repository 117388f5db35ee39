#!/usr/bin/env bash
# Compression against float32 at the same number of iterations (docs/results.md, "On all 200
# test views"): a float model is trained on to --at iterations, cnerf encodes it to --size
# bytes in --iters more iterations, and a copy of the float model trains for as many more,
# so that the file and the float model it is compared with have trained equally long. All
# three are scored on the test split (every --every-th view, default all of them).
#   experiments/rd_goal.sh OUT DATASET FLOAT.CKPT [--at N] [--iters N] [--size BYTES]
#                      [--seed S] [--preset P] [--downscale F] [--threads T] [--every N]
#                      [--average N]
# FLOAT.CKPT is a float checkpoint of DATASET (experiments/rd_converged.sh leaves one in
# OUT/rd/float.ckpt); it is copied, never changed. Defaults: --at 32000 --iters 12000
# --size 60000 --seed 1 --preset small --downscale 4 --threads 2 --every 1; --average N
# passes encode --average N (the file holds the mean of its last N iterations).
# Writes OUT/goal.csv and OUT/goal.md. Resumes: finished steps are kept, an interrupted
# training or encode continues from its checkpoint. CNERF=path runs another binary.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?output directory} data=${2:?dataset} float=${3:?float checkpoint}
shift 3
at=32000 iters=12000 size=60000 seed=1 preset=small downscale=4 threads=2 every=1 average=0
while [ $# -gt 0 ]; do
  case $1 in
    --at) at=$2 ;; --iters) iters=$2 ;; --size) size=$2 ;; --seed) seed=$2 ;;
    --preset) preset=$2 ;; --downscale) downscale=$2 ;; --threads) threads=$2 ;;
    --every) every=$2 ;; --average) average=$2 ;;
    *) echo "rd_goal.sh: unknown option $1" >&2; exit 2 ;;
  esac
  shift 2
done
cnerf=${CNERF:-build/cnerf}
[ -f "$float" ] || { echo "rd_goal.sh: no float checkpoint $float" >&2; exit 1; }
mkdir -p "$out"
common=(--downscale "$downscale" --threads "$threads")
end=$((at + iters))

# A copy of the float model trained on to N iterations: OUT/float-N.ckpt (and its log).
float_to() {
  local n=$1 from=$2 ckpt=$out/float-$1.ckpt
  grep -q "^saved .* at iteration $n:" "$out/float-$n.log" 2>/dev/null && return 0
  [ -f "$ckpt" ] || cp "$from" "$ckpt"
  echo "rd_goal.sh: training the float model on to $n iterations" >&2
  "$cnerf" train "$data" -o "$ckpt" --preset "$preset" --iters "$n" "${common[@]}" --resume \
    > "$out/float-$n.log" 2>&1 || { echo "rd_goal.sh: training failed (see $out/float-$n.log)" >&2; exit 1; }
}

# The mean test PSNR of a float checkpoint: OUT/NAME.eval.
score() {
  local ckpt=$1 log=$out/$2.eval
  grep -q "^mean over" "$log" 2>/dev/null && return 0
  "$cnerf" eval "$ckpt" "$data" "${common[@]}" --every "$every" > "$log" 2>&1 ||
    { echo "rd_goal.sh: eval of $ckpt failed (see $log)" >&2; exit 1; }
}

float_to "$at" "$float"
file=$out/cnerf-$size.cnrf
if ! grep -q "^test: " "$out/cnerf-$size.log" 2>/dev/null; then
  echo "rd_goal.sh: encoding to $size bytes in $iters iterations" >&2
  start=(--init "$out/float-$at.ckpt")
  [ -f "$file.ckpt" ] && start=(--resume "$file.ckpt")
  [ "$average" = 0 ] || start+=(--average "$average")
  rm -f "$file"
  # An encode that ends off its target still writes the file and exits 1: its row is kept.
  "$cnerf" encode "$data" -o "$file" --size "$size" "${start[@]}" --preset "$preset" \
    --iters "$iters" --seed "$seed" --every "$every" "${common[@]}" \
    > "$out/cnerf-$size.log" 2>&1 || [ -f "$file" ] ||
    { echo "rd_goal.sh: encode failed (see $out/cnerf-$size.log)" >&2; exit 1; }
fi
float_to "$end" "$out/float-$at.ckpt"
score "$out/float-$at.ckpt" "float-$at"
score "$out/float-$end.ckpt" "float-$end"

params=$(sed -n 's/^model: .* \([0-9]*\) parameters$/\1/p' "$out/float-$at.log" | head -1)
[ -n "$params" ] || { echo "rd_goal.sh: no parameter count in $out/float-$at.log" >&2; exit 1; }
fpsnr() { sed -n 's/^mean over .* psnr \([0-9.]*\) dB.*/\1/p' "$out/$1.eval"; }
bytes=$(stat -c %s "$file")
cpsnr=$(sed -n 's/^test: .* psnr \([0-9.]*\) dB.*/\1/p' "$out/cnerf-$size.log")
[ -n "$cpsnr" ] || { echo "rd_goal.sh: no test PSNR in $out/cnerf-$size.log" >&2; exit 1; }
csv=$out/goal.csv
{
  echo "model,iterations,bytes,test_psnr_db"
  echo "float32,$at,$((4 * params)),$(fpsnr "float-$at")"
  echo "cnerf,$end,$bytes,$cpsnr"
  echo "float32,$end,$((4 * params)),$(fpsnr "float-$end")"
} > "$csv"
awk -F, 'NR == 4 { fb = $3; fp = $4 } { row[NR] = $0 }
  END {
    print "| model | iterations | bytes | float32 size / size | test PSNR (dB) | vs float32 at " \
          "as many iterations (dB) |"
    print "|---|---|---|---|---|---|"
    for (i = 2; i <= 4; i++) {
      split(row[i], f, ",")
      printf "| %s | %d | %d | %.1f | %.2f | %+.2f |\n", f[1], f[2], f[3], fb / f[3], f[4],
             f[4] - fp
    }
  }' "$csv" > "$out/goal.md"
cat "$out/goal.md"
