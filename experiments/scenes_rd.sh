#!/usr/bin/env bash
# Two scenes in one stream against two streams (the paper's multi-scene experiment): at each
# lambda, `cnerf encode A B` (shared shifts) and `cnerf encode A` + `cnerf encode B`, with the
# same options. Compares the joint stream's size with the sum of the two single-scene
# streams, at the mean test PSNR of the pair. Writes OUT/scenes_rd.csv, OUT/scenes_rd.md and,
# with gnuplot, OUT/scenes_rd.png.
#   experiments/scenes_rd.sh OUT DATASET_A DATASET_B "LAMBDAS" [-- ENCODE OPTIONS]
# Options default to "--preset tiny --downscale 4 --iters 3000 --every 8". Runs one after the
# other on every core; a run whose log has its test line is not run again, so an interrupted
# sweep picks up where it stopped (an interrupted run restarts from its checkpoint).
# CNERF=path runs another cnerf binary than build/cnerf.
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 4 ] || { echo "usage: experiments/scenes_rd.sh OUT DATASET_A DATASET_B \"LAMBDAS\" [-- OPTIONS]" >&2; exit 2; }
out=$1 a=$2 b=$3 lambdas=$4
shift 4
[ $# -gt 0 ] && [ "$1" = "--" ] && shift
opts=("$@")
[ ${#opts[@]} -gt 0 ] || opts=(--preset tiny --downscale 4 --iters 3000 --every 8)
cnerf=${CNERF:-build/cnerf}
[ -x "$cnerf" ] || { echo "scenes_rd.sh: build first (scripts/test.sh)" >&2; exit 1; }
mkdir -p "$out"

# run NAME DATASET...: one encode into OUT/NAME.cnrf, resumed from its checkpoint if any.
run() {
  local name=$1 lambda=$2
  shift 2
  local log=$out/$name.log
  if grep -q '^test: ' "$log" 2> /dev/null; then return 0; fi
  local resume=()
  [ -s "$out/$name.cnrf.ckpt" ] && resume=(--resume "$out/$name.cnrf.ckpt")
  echo "scenes_rd.sh: $name" >&2
  "$cnerf" encode "$@" -o "$out/$name.cnrf" --force --lambda "$lambda" --prune off --log-every 250 \
    "${opts[@]}" "${resume[@]}" >> "$log" 2>&1 ||
    echo "scenes_rd.sh: $name failed (see $log)" >&2
}

csv=$out/scenes_rd.csv
echo "lambda,a_bytes,a_psnr,b_bytes,b_psnr,joint_bytes,joint_shared_bytes,joint_a_psnr,joint_b_psnr" > "$csv"
for l in $lambdas; do
  run "a-$l" "$l" "$a"
  run "b-$l" "$l" "$b"
  run "joint-$l" "$l" "$a" "$b"
  size() { stat -c %s "$out/$1.cnrf" 2> /dev/null || echo 0; }
  psnr() { sed -n 's/^test: .* psnr \([0-9.]*\) dB.*/\1/p' "$out/$1.log" | tail -1; }
  jpsnr() { sed -n "s/^scene $1: .* psnr \\([0-9.]*\\) dB.*/\\1/p" "$out/joint-$l.log" | tail -1; }
  shared=$(sed -n 's/^wrote .* shared shifts \([0-9]*\) bytes$/\1/p' "$out/joint-$l.log" | tail -1)
  echo "$l,$(size "a-$l"),$(psnr "a-$l"),$(size "b-$l"),$(psnr "b-$l"),$(size "joint-$l"),${shared:-},$(jpsnr 0),$(jpsnr 1)" >> "$csv"
done
cat "$csv"
# The last two columns compare at equal quality: the bytes the two streams would need for the
# joint stream's mean PSNR, read off the two-stream curve linearly in PSNR against log bytes
# between its neighbouring points (beyond its ends, along its first or last segment; "-"
# with fewer than two points).
{
  echo "| λ | two streams (bytes) | mean PSNR (dB) | one stream (bytes) | of which shared | mean PSNR (dB) | one / two | two streams at the one stream's PSNR (bytes) | one / two at equal PSNR |"
  echo "|---|---|---|---|---|---|---|---|---|"
  tail -n +2 "$csv" | awk -F, '
    $2 && $4 { n++; tb[n] = $2 + $4; tq[n] = ($3 + $5) / 2 }
    $2 && $6 { m++; row[m] = $0 }
    END {
      for (i = 1; i <= n; i++) for (j = i + 1; j <= n; j++) if (tq[j] < tq[i]) {
        x = tq[i]; tq[i] = tq[j]; tq[j] = x; x = tb[i]; tb[i] = tb[j]; tb[j] = x }
      for (k = 1; k <= m; k++) {
        split(row[k], f, ",")
        q = (f[8] + f[9]) / 2; eq = "-"; ratio = "-"
        if (n >= 2) {
          i = 1
          while (i < n - 1 && q > tq[i + 1]) i++
          lb = log(tb[i]) + (q - tq[i]) * (log(tb[i + 1]) - log(tb[i])) / (tq[i + 1] - tq[i])
          eq = sprintf("%d", exp(lb) + 0.5); ratio = sprintf("%.3f", f[6] / exp(lb))
        }
        printf "| %s | %d | %.2f | %d | %d | %.2f | %.3f | %s | %s |\n", f[1], f[2] + f[4],
               (f[3] + f[5]) / 2, f[6], f[7], q, f[6] / (f[2] + f[4]), eq, ratio
      }
    }'
} > "$out/scenes_rd.md"
cat "$out/scenes_rd.md"
if command -v gnuplot > /dev/null; then
  gnuplot <<GP
set terminal pngcairo size 800,520 noenhanced
set output "$out/scenes_rd.png"
set datafile separator ","
set logscale x
set xlabel "bytes for both scenes"
set ylabel "mean test PSNR of the two scenes (dB)"
set key bottom right
set grid
set title "$(basename "$a") + $(basename "$b"): ${opts[*]}"
plot "< tail -n +2 $csv | sort -t, -k6 -n" using 6:((\$8+\$9)/2) with linespoints lw 2 pt 7 title "one stream, shared shifts", \
     "< tail -n +2 $csv | sort -t, -k2 -n" using (\$2+\$4):((\$3+\$5)/2) with linespoints lw 2 pt 5 title "two streams"
GP
  echo "scenes_rd.sh: wrote $out/scenes_rd.png"
fi
