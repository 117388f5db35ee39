#!/usr/bin/env bash
# The occupancy grid's resolution against the decoder's work, on one trained model: exports
# the checkpoint of a finished `cnerf encode` at each grid resolution (16, 32, 64, 128 cells
# per axis, and none), renders the test views with the fixed-point decoder, and prints one
# markdown row per resolution: stream bytes, grid bytes and occupancy, network evaluations per
# ray (and the in-bounds samples a decoder without the grid evaluates), test PSNR of the
# fixed-point decoder and of the float reference.
#
#   experiments/grid_sweep.sh CKPT DATASET OUT -- ENCODE_OPTIONS...
#
# ENCODE_OPTIONS are the encode's own (--lambda, --preset, --downscale, --iters, ...), so that
# the checkpoint resumes with nothing left to train; the test views are every 40th (RENDER_EVERY).
# Example: experiments/grid_sweep.sh out/lego.cnrf.ckpt ../shared/data/lego out/grid -- \
#   --lambda 3 --preset small --downscale 4 --iters 3000
set -euo pipefail
[ $# -ge 4 ] && [ "$4" = "--" ] || { sed -n '2,14p' "$0" >&2; exit 2; }
ckpt=$1 data=$2 out=$3
shift 4
cnerf=${CNERF:-build/cnerf}
every=${RENDER_EVERY:-40}
ds=$(printf '%s\n' "$@" | sed -n '/^--downscale$/{n;p}')
mkdir -p "$out"
echo "| grid | file (bytes) | grid (bytes) | occupied | evaluations per ray | in-bounds samples per ray | fixed-point PSNR (dB) | float reference PSNR (dB) |"
echo "|---|---|---|---|---|---|---|---|"
for g in 0 16 32 64 128; do
  cp "$ckpt" "$out/g$g.cnrf.ckpt"
  "$cnerf" encode "$data" -o "$out/g$g.cnrf" --resume "$out/g$g.cnrf.ckpt" --grid "$g" \
    --every "$every" "$@" > "$out/encode_g$g.log"
  "$cnerf" render "$out/g$g.cnrf" --dataset "$data" ${ds:+--downscale "$ds"} --every "$every" \
    > "$out/render_g$g.log"
  bytes=$(stat -c %s "$out/g$g.cnrf")
  read -r gb occ < <("$cnerf" info --no-estimate "$out/g$g.cnrf" |
    sed -n 's/^occupancy grid: [0-9]*^3 cells, \([0-9]*\) bytes, [0-9]* occupied (\(.*\))$/\1 \2/p;
            s/^occupancy grid: none.*/0 -/p')
  read -r ev ib < <(sed -n 's/^network evaluations per ray: \([0-9.]*\) (\([0-9.]*\) .*/\1 \2/p' \
    "$out/render_g$g.log")
  read -r fx fl < <(sed -n 's/^mean over .* psnr \([0-9.]*\) dB .*(float reference \([0-9.]*\) dB).*/\1 \2/p' \
    "$out/render_g$g.log")
  echo "| $([ "$g" = 0 ] && echo none || echo "$g³") | $bytes | $gb | $occ | $ev | $ib | $fx | $fl |"
done
