#!/usr/bin/env bash
# Test PSNR against training wall-clock time, for presets tiny and small on Lego at 100x100:
# one `cnerf train --eval-every N` run per preset (both threads), which prints the test PSNR
# of views r_0, r_40, ..., r_160 every N iterations together with the training time so far
# (evaluations left out of the clock). Writes OUT/psnr_time.csv, OUT/psnr_time.md (a table)
# and, with gnuplot, OUT/psnr_time.png.
#   scripts/psnr_time.sh [OUT] [ITERS] [EVAL_EVERY] [PRESETS]
# Defaults: out/psnr_time, 4000 iterations, an evaluation every 250, "tiny small".
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/psnr_time}; iters=${2:-4000}; every=${3:-250}; presets=${4:-tiny small}
data=../shared/data/lego
cnerf=${CNERF:-build/cnerf}
[ -x "$cnerf" ] || { echo "psnr_time.sh: build first (scripts/test.sh)" >&2; exit 1; }
mkdir -p "$out"
csv=$out/psnr_time.csv
echo "preset,iteration,train_seconds,test_psnr_db,test_ssim" > "$csv"
for p in $presets; do
  log=$out/train-$p.log
  echo "psnr_time.sh: $p, $iters iterations" >&2
  "$cnerf" train "$data" -o "$out/$p.ckpt" --preset "$p" --downscale 4 --iters "$iters" \
    --eval-every "$every" --every 40 --log-every "$every" > "$log"
  sed -n "s/^eval: iteration \([0-9]*\), training \([0-9.]*\) s, test psnr \([0-9.]*\) dB, ssim \([-0-9.]*\),.*/$p,\1,\2,\3,\4/p" \
    "$log" >> "$csv"
done
{
  echo "| preset | iteration | training time (s) | test PSNR (dB) | SSIM |"
  echo "|---|---|---|---|---|"
  tail -n +2 "$csv" | awk -F, '{ printf "| %s | %d | %.1f | %.2f | %.4f |\n", $1, $2, $3, $4, $5 }'
} > "$out/psnr_time.md"
cat "$out/psnr_time.md"
if command -v gnuplot > /dev/null; then
  plot=""
  for p in $presets; do
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
