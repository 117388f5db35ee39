#!/usr/bin/env bash
# Test PSNR against training wall-clock time, for presets tiny and small on Lego at 100x100:
# one `cnerf train --eval-every N` run per preset (both threads), which prints the test PSNR
# of views r_0, r_40, ..., r_160 every N iterations together with the training time so far
# (evaluations left out of the clock). Writes OUT/psnr_time.csv, OUT/psnr_time.md (the table,
# then the plateau: means of 5 evaluations and their gains) and, with gnuplot, OUT/psnr_time.png.
#   experiments/psnr_time.sh [OUT] [ITERS] [EVAL_EVERY] [PRESETS]
# TRAIN_OPTS="..." adds options to every `cnerf train` (e.g. "--lr 5e-4 --lr-decay 500000",
# the schedule of the curves in docs/training.md).
# Defaults: out/psnr_time, 4000 iterations, an evaluation every 250, "tiny small". A preset
# written NAME:N trains to N iterations instead of ITERS (e.g. "tiny:60000 small:40000").
# Run again on the same OUT with a larger ITERS to extend the curves: each preset resumes
# from OUT/PRESET.ckpt, its log grows, and the times of a resumed run continue from the last
# time the log holds.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/psnr_time}; iters=${2:-4000}; every=${3:-250}; presets=${4:-tiny small}
data=../shared/data/lego
cnerf=${CNERF:-build/cnerf}
[ -x "$cnerf" ] || { echo "psnr_time.sh: build first (scripts/test.sh)" >&2; exit 1; }
mkdir -p "$out"
csv=$out/psnr_time.csv
echo "preset,iteration,train_seconds,test_psnr_db,test_ssim" > "$csv"
names=""
for spec in $presets; do
  p=${spec%%:*}; n=$iters
  [ "$p" = "$spec" ] || n=${spec#*:}
  names="$names $p"
  log=$out/train-$p.log
  resume=()
  if [ -f "$out/$p.ckpt" ] && [ -f "$log" ]; then
    resume=(--resume)
  else
    : > "$log"
  fi
  echo "psnr_time.sh: $p, to $n iterations${resume:+ (resumed)}" >&2
  echo "psnr_time.sh: run" >> "$log"
  "$cnerf" train "$data" -o "$out/$p.ckpt" --force --preset "$p" --downscale 4 --iters "$n" \
    --eval-every "$every" --every 40 --log-every "$every" ${TRAIN_OPTS:-} "${resume[@]}" >> "$log"
  # Each run's clock starts at zero; a resumed run's times continue from the training time
  # that the runs before it report when they save ("saved ... at iteration N: S s, ..."), or
  # for a run that was killed, from its last evaluation (its last checkpoint is of that step).
  awk -v p="$p" '
    /^psnr_time.sh: run/ { base += ran; ran = 0; next }
    /^(interrupted: )?saved .* at iteration [0-9]+: [0-9.]+ s,/ {
      ran = $0; sub(/.* at iteration [0-9]+: /, "", ran); sub(/ s,.*/, "", ran); ran += 0
    }
    /^eval: iteration/ {
      it = $3; sub(",", "", it); ssim = $12; sub(",", "", ssim)
      ran = $5 + 0
      printf "%s,%d,%.1f,%s,%s\n", p, it, base + ran, $9, ssim
    }' "$log" >> "$csv"
done
{
  echo "| preset | iteration | training time (s) | test PSNR (dB) | SSIM |"
  echo "|---|---|---|---|---|"
  tail -n +2 "$csv" | awk -F, '{ printf "| %s | %d | %.1f | %.2f | %.4f |\n", $1, $2, $3, $4, $5 }'
  echo
  # The plateau: means of W = 5 consecutive evaluations per preset, the gain of each mean
  # over the one before per 1000 iterations, and the first mean that gains less than
  # G = 0.1 dB per 1000 iterations.
  awk -v W=5 -v G=0.1 '
    BEGIN { FS = ","; print "| preset | iterations | training time at its end (s) | mean test PSNR (dB) | gain per 1000 iterations (dB) |"; print "|---|---|---|---|---|" }
    function flush(   m, g, gs, note) {
      if (k == 0) return
      m = sum / k; gs = ""; note = ""
      if (have) {
        g = (m - pm) / ((last - plast) / 1000); gs = sprintf("%+.3f", g)
        if (!flat && g < G) { flat = 1; note = " (plateau)" }
      }
      printf "| %s | %d–%d | %.0f | %.2f | %s%s |\n", p, first, last, t, m, gs, note
      pm = m; plast = last; have = 1; k = 0; sum = 0
    }
    NR > 1 {
      if ($1 != p) { flush(); p = $1; have = 0; flat = 0 }
      if (k == 0) first = $2
      sum += $4; k++; last = $2; t = $3
      if (k == W) flush()
    }
    END { flush() }
  ' "$csv"
} > "$out/psnr_time.md"
cat "$out/psnr_time.md"
if command -v gnuplot > /dev/null; then
  plot=""
  for p in $names; do
    plot="${plot:+$plot, }\"< grep '^$p,' $csv\" using 3:4 with linespoints lw 2 title \"$p\""
  done
  gnuplot <<GP
set terminal pngcairo size 800,520 noenhanced
set output "$out/psnr_time.png"
set datafile separator ","
set xlabel "training time, 2 threads (s)"
set ylabel "test PSNR, r_0 ... r_160 (dB)"
set key bottom right
set grid
set title "cnerf train on Lego 100x100: test PSNR against wall-clock time"
plot $plot
GP
  echo "psnr_time.sh: wrote $out/psnr_time.png" >&2
else
  echo "psnr_time.sh: gnuplot not found (apt-get install gnuplot-nox): no chart" >&2
fi
