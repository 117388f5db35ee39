#!/usr/bin/env bash
# The learning rate's warm-up in the encoder, on Lego and Fern (docs/training.md, "Warm-up"):
#   experiments/warmup_encode.sh OUT [DATA]
# The README main job's encode on one thread (preset tiny, --downscale 4, 2000 iterations,
# seed 1), rounded from the first iteration (--float-iters 0), without and with
# --lr-warmup 20: Lego at --lambda 0.1 and at --size 20200, Fern at --lambda 0.1; each
# scored by cnerf eval on every test view. Writes OUT/warmup_encode.md.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: experiments/warmup_encode.sh OUT [DATA]} data=${2:-../shared/data}
cnerf=${CNERF:-./build/cnerf}
mkdir -p "$out"
echo "| scene, target | without: PSNR, bytes | with: PSNR, bytes |" > "$out/warmup_encode.md"
echo "|---|---|---|" >> "$out/warmup_encode.md"
for c in "lego|--lambda 0.1" "lego|--size 20200" "fern|--lambda 0.1"; do
  scene=${c%%|*} target=${c#*|}
  row="| $scene, \`$target\` |"
  for w in 0 20; do
    f=$out/$scene-${target// /}-w$w.cnrf
    [ -s "$f" ] || "$cnerf" encode "$data/$scene" -o "$f" --force $target --preset tiny \
      --downscale 4 --iters 2000 --threads 1 --seed 1 --lr-warmup $w --float-iters 0 \
      > "$f.log" 2>&1
    psnr=$("$cnerf" eval "$f" "$data/$scene" --downscale 4 --every 1 --threads 1 |
             sed -n 's/^mean over .* psnr \([0-9.]*\) dB.*/\1/p')
    row="$row $psnr dB, $(stat -c %s "$f") B |"
  done
  echo "$row" >> "$out/warmup_encode.md"
done
cat "$out/warmup_encode.md"
