#!/usr/bin/env bash
# Test PSNR against training time for two learning-rate schedules on one dataset: NeRF's
# (--lr 5e-4, tenfold decay over 500,000 iterations) and cnerf's default (5e-3, tenfold over
# the run). One `cnerf train --eval-every N` run each, one after the other, both threads.
# Writes OUT/lr_time.csv (schedule, iteration, training seconds without the evaluations,
# test PSNR, SSIM), OUT/lr_time.md (the table) and, with gnuplot, OUT/lr_time.png.
#   experiments/lr_time.sh OUT DATASET [ITERS] [EVAL_EVERY] [-- TRAIN OPTIONS]
# Defaults: 3000 iterations, an evaluation every 250; the options default to
# "--preset tiny --downscale 4 --every 40" (give e.g. "--preset tiny --downscale 4 --every 1"
# for an LLFF scene, whose test views are every 8th image).
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 2 ] || { echo "usage: experiments/lr_time.sh OUT DATASET [ITERS] [EVAL_EVERY] [-- OPTIONS]" >&2; exit 2; }
out=$1; data=$2; shift 2
iters=3000; every=250
if [ $# -gt 0 ] && [ "$1" != "--" ]; then iters=$1; shift; fi
if [ $# -gt 0 ] && [ "$1" != "--" ]; then every=$1; shift; fi
[ $# -gt 0 ] && [ "$1" = "--" ] && shift
opts=("$@")
[ ${#opts[@]} -gt 0 ] || opts=(--preset tiny --downscale 4 --every 40)
cnerf=${CNERF:-build/cnerf}
[ -x "$cnerf" ] || { echo "lr_time.sh: build first (scripts/test.sh)" >&2; exit 1; }
mkdir -p "$out"
csv=$out/lr_time.csv
echo "schedule,iteration,train_seconds,test_psnr_db,test_ssim" > "$csv"
declare -A sched=([nerf]="--lr 5e-4 --lr-decay 500000" [default]="")
for name in nerf default; do
  echo "lr_time.sh: $name schedule ${sched[$name]:-(5e-3 over the run)}, $iters iterations" >&2
  # shellcheck disable=SC2086 # the schedule's options are words
  "$cnerf" train "$data" -o "$out/$name.ckpt" --force --iters "$iters" --eval-every "$every" \
    --log-every "$every" "${opts[@]}" ${sched[$name]} > "$out/train-$name.log"
  awk -v p="$name" '/^eval: iteration/ {
      it = $3; sub(",", "", it); ssim = $12; sub(",", "", ssim)
      printf "%s,%d,%.1f,%s,%s\n", p, it, $5, $9, ssim }' "$out/train-$name.log" >> "$csv"
done
{
  echo "| schedule | iteration | training time (s) | test PSNR (dB) | SSIM |"
  echo "|---|---|---|---|---|"
  tail -n +2 "$csv" | awk -F, '{ printf "| %s | %d | %.1f | %.2f | %.4f |\n", $1, $2, $3, $4, $5 }'
} > "$out/lr_time.md"
cat "$out/lr_time.md"
if command -v gnuplot > /dev/null; then
  gnuplot <<GP
set terminal pngcairo size 800,520 noenhanced
set output "$out/lr_time.png"
set datafile separator ","
set xlabel "training time, 2 threads (s)"
set ylabel "test PSNR (dB)"
set key bottom right
set grid
set title "cnerf train on $(basename "$data"): ${opts[*]}"
plot "< grep '^nerf,' $csv" using 3:4 with linespoints lw 2 title "NeRF: 5e-4, tenfold over 500k", \
     "< grep '^default,' $csv" using 3:4 with linespoints lw 2 title "default: 5e-3, tenfold over the run"
GP
  echo "lr_time.sh: wrote $out/lr_time.png" >&2
else
  echo "lr_time.sh: gnuplot not found (apt-get install gnuplot-nox): no chart" >&2
fi
