#!/usr/bin/env bash
# Decoder memory for each preset, as docs/decoder.md's table states it: latents, workspace
# (latents at one byte each, as every trained stream of these presets has them; two bytes for
# a layer whose latents leave the int8 range), render scratch. Streams from `cnerf synth`
# (the topology is what matters). Needs build/cnerf (scripts/test.sh builds it).
set -euo pipefail
cd "$(dirname "$0")/.."
cnerf=${CNERF:-build/cnerf}
[ -x "$cnerf" ] || { echo "decoder_memory.sh: build first (scripts/test.sh)" >&2; exit 1; }
tmp=$(mktemp)
trap 'rm -f "$tmp"' EXIT
echo "| preset | latents | biases | workspace bytes | render scratch bytes |"
echo "|---|---|---|---|---|"
for p in tiny small paper; do
  "$cnerf" synth -o "$tmp" --preset $p > /dev/null
  "$cnerf" info --no-estimate "$tmp" | awk -v p=$p '
    /^parameters:/ {lat = $2; bias = $4}
    /^decoder memory:/ {
      ws = $4
      for (i = 5; i < NF; i++) if ($i == "scratch") sc = $(i + 1)
    }
    END {printf "| `%s` | %d | %d | %d | %d |\n", p, lat, bias, ws, sc}'
done
