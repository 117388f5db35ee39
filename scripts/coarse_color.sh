#!/usr/bin/env bash
# What not sending the coarse network's colour (encode --coarse-color off) and weighing its
# error less (--coarse-weight W) are worth (docs/results.md, "The coarse network's colour"):
# the same encode with the colour sent at weight 1 (the defaults before), not sent at
# weight 1, and not sent at each weight of WEIGHTS (0.1, the default, first).
#   scripts/coarse_color.sh OUT NAME DATASET [--weights "W ..."] [--threads T] -- ENCODE OPTIONS
# e.g. the README's main job:
#   scripts/coarse_color.sh out/cc lego-main ../shared/data/lego -- --lambda 0.1 --preset tiny \
#     --downscale 4 --iters 2000 --every 40
# Writes OUT/NAME-<variant>.cnrf and .log (a finished variant is kept) and appends the rows
# of a markdown table to OUT/NAME.md: variant, bytes, test PSNR, SSIM.
# CNERF=path runs another cnerf binary than build/cnerf.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?output directory} name=${2:?name} data=${3:?dataset}
shift 3
weights="0.1" threads=$(nproc)
while [ $# -gt 0 ]; do
  case $1 in
    --weights) weights=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --) shift; break ;;
    *) echo "coarse_color.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
cnerf=${CNERF:-build/cnerf}
[ -x "$cnerf" ] || { echo "coarse_color.sh: no $cnerf (build first)" >&2; exit 1; }
mkdir -p "$out"
variants=("on 1" "off 1")
for w in $weights; do variants+=("off $w"); done
md=$out/$name.md
echo "| coarse colour | coarse weight | bytes | test PSNR (dB) | SSIM |" > "$md"
echo "|---|---|---|---|---|" >> "$md"
for v in "${variants[@]}"; do
  read -r cc w <<< "$v"
  f=$out/$name-$cc-$w
  if ! grep -q "^test: " "$f.log" 2> /dev/null || [ ! -s "$f.cnrf" ]; then
    echo "coarse_color.sh: $name, coarse colour $cc, weight $w" >&2
    "$cnerf" encode "$data" -o "$f.cnrf" --threads "$threads" --coarse-color "$cc" \
      --coarse-weight "$w" "$@" > "$f.log" 2>&1 ||
      { echo "coarse_color.sh: encode failed (see $f.log)" >&2; exit 1; }
  fi
  read -r psnr ssim < <(sed -n 's/^test: [0-9]* views, psnr \([0-9.]*\) dB, ssim \([0-9.]*\),.*/\1 \2/p' "$f.log")
  echo "| $([ "$cc" = on ] && echo sent || echo "not sent") | $w | $(stat -c %s "$f.cnrf") | $psnr | $ssim |" >> "$md"
done
cat "$md"
