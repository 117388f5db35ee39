#!/usr/bin/env bash
# The quality knob measured: on one dataset, `cnerf encode --quality Q` for each Q and one
# `cnerf train` of the same preset and iterations (the uncompressed model), one after the
# other, both threads. Run it once per scene with the same OUT: the table covers every scene
# whose logs are in OUT.
#   experiments/quality.sh OUT DATASET "QUALITIES" [-- OPTIONS]
# The options default to "--preset tiny --downscale 4 --iters 3000 --every 40" (give
# "--every 1" for an LLFF scene, whose test views are every 8th image). Logs are
# OUT/SCENE-float.log and OUT/SCENE-qQ.log (SCENE: the dataset's directory name); a run
# whose log is complete is not run again, so an interrupted sweep resumes where it stopped.
# Writes OUT/quality.csv and OUT/quality.md: per scene and Q the file's bytes and bits per
# latent, the final lambda (also in units of 3 pixels / latents), the test PSNR and its loss
# against the uncompressed model.
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 3 ] || { echo "usage: experiments/quality.sh OUT DATASET \"QUALITIES\" [-- OPTIONS]" >&2; exit 2; }
out=$1; data=$2; qs=$3; shift 3
[ $# -gt 0 ] && [ "$1" = "--" ] && shift
opts=("$@")
[ ${#opts[@]} -gt 0 ] || opts=(--preset tiny --downscale 4 --iters 3000 --every 40)
iters=3000
for ((i = 0; i < ${#opts[@]} - 1; i++)); do
  [ "${opts[$i]}" != "--iters" ] || iters=${opts[$((i + 1))]}
done
cnerf=${CNERF:-build/cnerf}
[ -x "$cnerf" ] || { echo "quality.sh: build first (scripts/test.sh)" >&2; exit 1; }
mkdir -p "$out"
scene=$(basename "$data")
log=$out/$scene-float.log
if ! grep -q "^eval: iteration $iters," "$log" 2> /dev/null; then
  echo "quality.sh: $scene, uncompressed" >&2
  "$cnerf" train "$data" -o "$out/$scene-float.ckpt" --force --eval-every "$iters" --log-every 250 \
    --ckpt-secs 100000 "${opts[@]}" > "$log" 2>&1
fi
for q in $qs; do
  log=$out/$scene-q$q.log
  if ! grep -q '^test:' "$log" 2> /dev/null; then
    echo "quality.sh: $scene, quality $q" >&2
    "$cnerf" encode "$data" -o "$out/$scene-q$q.cnrf" --force --quality "$q" --log-every 250 \
      --ckpt-secs 100000 "${opts[@]}" > "$log" 2>&1
  fi
done
csv=$out/quality.csv
echo "scene,quality,slope_db_per_bit,file_bytes,latents,bits_per_latent,final_lambda,lambda_per_unit,test_psnr_db,float_psnr_db,loss_db" > "$csv"
for f in "$out"/*-float.log; do
  s=$(basename "$f" -float.log)
  fp=$(awk '/^eval: iteration/ { p = $9 } END { print p }' "$f")
  for g in "$out/$s"-q*.log; do
    [ -e "$g" ] || continue
    awk -v s="$s" -v fp="$fp" '
      /^encoding / { for (i = 1; i <= NF; i++) if ($i == "latents,") n = $(i - 1) }
      /^quality: / { q = $2; k = $3; sub(/[(]/, "", k); l = $11; u = $13 }
      /^test: / { p = $5; b = $(NF - 1) }
      END { if (p != "") printf "%s,%s,%s,%d,%d,%.3f,%s,%s,%s,%s,%.2f\n", s, q, k, b, n,
                                8 * b / n, l, u, p, fp, fp - p }' "$g"
  done
done | sort -t, -k1,1 -k2,2n >> "$csv"
{
  echo "| scene | Q | dB per bit per latent | file (bytes) | bits per latent | final λ | λ / (3 pixels / latents) | test PSNR (dB) | uncompressed (dB) | loss (dB) |"
  echo "|---|---|---|---|---|---|---|---|---|---|"
  tail -n +2 "$csv" | awk -F, '{ printf "| %s | %s | %s | %d | %.3f | %s | %s | %s | %s | %.2f |\n",
                                 $1, $2, $3, $4, $6, $7, $8, $9, $10, $11 }'
} > "$out/quality.md"
cat "$out/quality.md"
