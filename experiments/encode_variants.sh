#!/usr/bin/env bash
# One encode with several sets of extra options, a table row each (docs/results.md, "What
# does not move the point at 60 kB" and "What rounding alone costs"):
#   experiments/encode_variants.sh OUT DATASET [--threads T] --variant "NAME [OPTIONS]" ... \
#     -- ENCODE OPTIONS
# Each variant runs `cnerf encode DATASET -o OUT/NAME.cnrf ENCODE OPTIONS OPTIONS` (a
# variant's option given again replaces the common one). Writes OUT/NAME.cnrf and .log (a
# finished variant is kept; one whose file misses its --size is kept with a warning) and
# OUT/variants.md: name, options, bytes, test PSNR, SSIM.
# CNERF=path runs another cnerf binary than build/cnerf.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?output directory} data=${2:?dataset}
shift 2
threads=$(nproc) variants=()
while [ $# -gt 0 ]; do
  case $1 in
    --threads) threads=$2; shift 2 ;;
    --variant) variants+=("$2"); shift 2 ;;
    --) shift; break ;;
    *) echo "encode_variants.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
[ ${#variants[@]} -gt 0 ] || { echo "encode_variants.sh: give at least one --variant" >&2; exit 2; }
cnerf=${CNERF:-build/cnerf}
[ -x "$cnerf" ] || { echo "encode_variants.sh: no $cnerf (build first)" >&2; exit 1; }
mkdir -p "$out"
md=$out/variants.md
echo "| variant | options | bytes | test PSNR (dB) | SSIM |" > "$md"
echo "|---|---|---|---|---|" >> "$md"
for v in "${variants[@]}"; do
  read -r name opts <<< "$v"
  f=$out/$name
  if ! grep -q "^test: " "$f.log" 2> /dev/null || [ ! -s "$f.cnrf" ]; then
    echo "encode_variants.sh: $name ${opts:-}" >&2
    # shellcheck disable=SC2086 # the variant's options are words
    if ! "$cnerf" encode "$data" -o "$f.cnrf" --force --threads "$threads" "$@" ${opts:-} > "$f.log" 2>&1; then
      # a file written and scored that misses its --size says so and exits 1: keep the row
      grep -q "^test: " "$f.log" && [ -s "$f.cnrf" ] ||
        { echo "encode_variants.sh: encode failed (see $f.log)" >&2; exit 1; }
      echo "encode_variants.sh: $name: encode exited non-zero, the row is kept (see $f.log)" >&2
    fi
  fi
  read -r psnr ssim < <(sed -n 's/^test: [0-9]* views, psnr \([0-9.]*\) dB, ssim \(-\?[0-9.]*\),.*/\1 \2/p' "$f.log")
  echo "| $name | ${opts:-} | $(stat -c %s "$f.cnrf") | $psnr | $ssim |" >> "$md"
done
cat "$md"
