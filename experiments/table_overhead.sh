#!/usr/bin/env bash
# Table overhead against latent payload for synthetic models of each preset: latents drawn
# from a rounded Laplacian of scale SPREAD (0.5: mostly 0 and +-1, as strong rate penalties
# give; 8: wide). Prints a Markdown table. Usage: experiments/table_overhead.sh [BUILD_DIR]
set -euo pipefail
build=${1:-build}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "| preset | spread | latents | payload bytes | table bytes | tables / payload | file bytes |"
echo "|---|---|---|---|---|---|---|"
for preset in tiny small paper; do
  for spread in 0.5 2 8; do
    f=$tmp/$preset-$spread.cnrf
    "$build/cnerf" synth -o "$f" --preset "$preset" --spread "$spread" --seed 1 >/dev/null
    "$build/cnerf" info --no-estimate "$f" | awk -v p="$preset" -v s="$spread" '
      /latent payload/ {pay=$3} /frequency tables/ {tab=$3} /^  total/ {tot=$2}
      /^parameters:/ {lat=$2}
      END {printf "| %s | %s | %d | %d | %d | %.2f%% | %d |\n", p, s, lat, pay, tab, 100*tab/pay, tot}'
  done
done
