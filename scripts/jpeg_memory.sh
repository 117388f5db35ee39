#!/usr/bin/env bash
# Peak memory of loading a capture of full-size JPEG photos: makes an instant-ngp scene of N
# synthetic W x H JPEGs (tests/tools/make_jpeg_scene.c) and runs `cnerf views` on it with
# --max-size under /usr/bin/time -v. Writes OUT/jpeg_memory.md.
#   scripts/jpeg_memory.sh OUT [N [W [H [MAX_SIZE]]]]     (defaults 100 4000 3000 400)
# Needs about N x 3 MB of disk for the scene; the scene is kept for a rerun, delete OUT to
# start over.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?output directory}; n=${2:-100} w=${3:-4000} h=${4:-3000} max=${5:-400}
cnerf=${CNERF:-build/cnerf} make=${MAKE_SCENE:-build/tests/make_jpeg_scene}
[ -x "$cnerf" ] && [ -x "$make" ] || { echo "jpeg_memory.sh: build first" >&2; exit 1; }
scene=$out/scene-$n-${w}x$h
if [ ! -s "$scene/transforms.json" ]; then
  rm -rf "$scene"; mkdir -p "$scene"
  echo "jpeg_memory.sh: writing $n ${w}x$h JPEGs into $scene"
  "$make" "$scene" "$n" "$w" "$h"
fi
rm -rf "$out/views"; mkdir -p "$out/views"
/usr/bin/time -v "$cnerf" views "$scene" -o "$out/views" --max-size "$max" --split train \
  > "$out/views.log" 2> "$out/time.log"
rss=$(sed -n 's/.*Maximum resident set size (kbytes): //p' "$out/time.log")
wall=$(sed -n 's/.*Elapsed (wall clock) time (h:mm:ss or m:ss): //p' "$out/time.log")
jpeg_mb=$(du -sm "$scene" | cut -f1)
views=$(sed -n 's/^--max-size [0-9]*: downscale \([0-9]*\), views \([0-9x]*\)$/\1 \2/p' "$out/views.log")
f=${views%% *}; size=${views##* }
{
  echo "| photos | photo size | JPEG bytes on disk | --max-size | downscale | views | peak RSS | wall time |"
  echo "|---|---|---|---|---|---|---|---|"
  echo "| $n | ${w}×$h | ${jpeg_mb} MB | $max | $f | $size | $((rss / 1024)) MB | $wall |"
} > "$out/jpeg_memory.md"
cat "$out/jpeg_memory.md"
