#!/usr/bin/env bash
# Which preset is on the rate-distortion frontier at each file size: for every preset, one
# rate-controlled `cnerf encode --size S --preset P` per size (experiments/rate_control.sh, dual
# ascent), then the table of test PSNR by size and preset, the best per size marked.
#   experiments/presets.sh OUT DATASET "PRESETS" "SIZES" [-- ENCODE OPTIONS]
# e.g. experiments/presets.sh /tmp/p ../shared/data/lego "tiny small" "6000 12000 20000 40000 80000" \
#        -- --downscale 4 --iters 3000 --every 40
# Runs go to OUT/PRESET/ and resume as rate_control.sh's do. Writes OUT/presets.csv
# (preset, target, file, deviation, latents, bits per latent, test PSNR) and OUT/presets.md.
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 4 ] || { echo "usage: experiments/presets.sh OUT DATASET \"PRESETS\" \"SIZES\" [-- OPTIONS]" >&2; exit 2; }
out=$1; data=$2; presets=$3; sizes=$4; shift 4
[ $# -gt 0 ] && [ "$1" = "--" ] && shift
opts=("$@")
mkdir -p "$out"
csv=$out/presets.csv
echo "preset,target_bytes,file_bytes,deviation_percent,latents,bits_per_latent,test_psnr_db" > "$csv"
for p in $presets; do
  experiments/rate_control.sh "$out/$p" "$data" "$sizes" dual -- --preset "$p" "${opts[@]}" > /dev/null
  for s in $sizes; do
    log=$out/$p/dual-$s.log
    awk -v p="$p" -v s="$s" '
      /^encoding .* latents, checkpoint/ { n = $0; sub(/ latents, checkpoint.*/, "", n); sub(/.*, /, "", n) }
      /^size: / { f = $2; d = $8; sub(/[(]/, "", d); sub(/%[)],?/, "", d) }
      /^test: / { q = $5 }
      END { if (f != "" && n > 0) printf "%s,%s,%s,%s,%s,%.3f,%s\n", p, s, f, d, n, 8 * f / n, q }' \
      "$log" >> "$csv"
  done
done
# One row per size, one column per preset; the best PSNR of the row in bold. A file more
# than 3% off its target is shown in brackets (that preset cannot make that size).
awk -F, -v presets="$presets" '
  NR == 1 { next }
  { key = $2 SUBSEP $1; psnr[key] = $7; bpl[key] = $6; dev[key] = $4; seen[$2] = 1 }
  END {
    np = split(presets, P, " ")
    printf "| size (bytes) |"; for (i = 1; i <= np; i++) printf " %s: test PSNR (dB), bits per latent |", P[i]; print ""
    printf "|---|"; for (i = 1; i <= np; i++) printf "---|"; print ""
    n = 0; for (s in seen) S[++n] = s + 0
    for (i = 1; i <= n; i++) for (j = i + 1; j <= n; j++) if (S[j] < S[i]) { t = S[i]; S[i] = S[j]; S[j] = t }
    for (k = 1; k <= n; k++) {
      s = S[k]; best = ""
      for (i = 1; i <= np; i++) { key = s SUBSEP P[i]
        if ((key in psnr) && (dev[key] + 0 <= 3 && dev[key] + 0 >= -3) && (best == "" || psnr[key] > psnr[best])) best = key }
      printf "| %d |", s
      for (i = 1; i <= np; i++) { key = s SUBSEP P[i]
        if (!(key in psnr)) { printf " – |"; continue }
        cell = sprintf("%s, %s", psnr[key], bpl[key])
        if (dev[key] + 0 > 3 || dev[key] + 0 < -3) cell = "(" cell ", " dev[key] "% off)"
        else if (key == best) cell = "**" cell "**"
        printf " %s |", cell }
      print "" } }' "$csv" > "$out/presets.md"
cat "$out/presets.md"
