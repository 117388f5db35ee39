#!/usr/bin/env bash
# Rate control measured: one `cnerf encode --size S --rate-control C` per size and
# controller, one after the other (both threads), and the table of what each file came to.
#   experiments/rate_control.sh OUT DATASET "SIZES" ["CONTROLLERS"] [-- ENCODE OPTIONS]
# Controllers default to "pi dual"; the options to "--preset tiny --downscale 4 --iters 3000
# --every 40". Each run's log is OUT/C-S.log; a run whose log is complete is not run again,
# so an interrupted sweep resumes where it stopped. Writes OUT/rate_control.csv and
# OUT/rate_control.md (target, file, deviation, final lambda, test PSNR; the CSV also has
# the training time, which another job on the machine inflates).
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 3 ] || { echo "usage: experiments/rate_control.sh OUT DATASET \"SIZES\" [\"CONTROLLERS\"] [-- OPTIONS]" >&2; exit 2; }
out=$1; data=$2; sizes=$3; shift 3
ctls="pi dual"
if [ $# -gt 0 ] && [ "$1" != "--" ]; then ctls=$1; shift; fi
[ $# -gt 0 ] && [ "$1" = "--" ] && shift
opts=("$@")
[ ${#opts[@]} -gt 0 ] || opts=(--preset tiny --downscale 4 --iters 3000 --every 40)
cnerf=${CNERF:-build/cnerf}
[ -x "$cnerf" ] || { echo "rate_control.sh: build first (scripts/test.sh)" >&2; exit 1; }
mkdir -p "$out"
csv=$out/rate_control.csv
echo "controller,target_bytes,file_bytes,deviation_percent,final_lambda,test_psnr_db,train_seconds" > "$csv"
for c in $ctls; do
  for s in $sizes; do
    log=$out/$c-$s.log
    if ! grep -q '^test:' "$log" 2> /dev/null; then
      echo "rate_control.sh: $c, $s bytes" >&2
      # A miss beyond 3% makes encode fail; the sweep records it and goes on.
      "$cnerf" encode "$data" -o "$out/$c-$s.cnrf" --force --size "$s" --rate-control "$c" \
        --log-every 50 --ckpt-secs 100000 "${opts[@]}" > "$log" 2>&1 || true
    fi
    awk -v c="$c" -v s="$s" '
      /^saved .* at iteration/ { t = $0; sub(/.* at iteration [0-9]+: /, "", t); sub(/ s,.*/, "", t) }
      /^size: / { f = $2; d = $8; sub(/[(]/, "", d); sub(/%[)],?/, "", d); l = $11 }
      /^test: / { p = $5 }
      END { if (f != "") printf "%s,%s,%s,%s,%s,%s,%s\n", c, s, f, d, l, p, t }' "$log" >> "$csv"
  done
done
{
  echo "| controller | target (bytes) | file (bytes) | off target | final λ | test PSNR (dB) |"
  echo "|---|---|---|---|---|---|"
  tail -n +2 "$csv" | awk -F, '{ printf "| %s | %d | %d | %+.2f%% | %s | %s |\n", $1, $2, $3, $4, $5, $6 }'
} > "$out/rate_control.md"
cat "$out/rate_control.md"
