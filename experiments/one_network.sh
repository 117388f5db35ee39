#!/usr/bin/env bash
# One network sampled through the occupancy grid against the two-network default: the README
# main job's encode (Lego 100x100, preset tiny, lambda 0.1, 2,000 iterations, one thread) as it
# is (32 coarse + 32 fine samples, two networks) and with --fine 0 --coarse N for each N, each
# rendered by the fixed-point decoder on the five test views: file bytes, test PSNR, network
# evaluations per ray, multiply-accumulates per evaluation, and the cost model's Cortex-M4
# instructions per ray.
#   experiments/one_network.sh OUT [DATASET] [--coarse "64 128"] [--no-baseline] [--tag T]
#                              [-- ENCODE OPTIONS...]
# Options after -- go to every one-network encode (for example --group-penalty 0.01 or
# --lambda 0.05, which come after the defaults and so replace them); --tag T names those runs
# one-network-N-T; --no-baseline skips the two-network run. Runs whose render log is already in
# OUT are not run again.
# CNERF: the program (build/cnerf).
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: one_network.sh OUT [DATASET] [--coarse "64 128"] [--no-baseline] [--tag T] [-- OPTIONS]}
shift
data=../shared/data/lego
[ $# -gt 0 ] && [ "${1#--}" = "$1" ] && { data=$1; shift; }
coarse="64 128" baseline=1 tag=""
extra=()
while [ $# -gt 0 ]; do
  case $1 in
    --coarse) coarse=$2; shift 2 ;;
    --no-baseline) baseline=0; shift ;;
    --tag) tag=-$2; shift 2 ;;
    --) shift; extra=("$@"); break ;;
    *) echo "one_network.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
cnerf=${CNERF:-build/cnerf}
[ -x "$cnerf" ] || { echo "one_network.sh: $cnerf: no such program (build the tree first)" >&2; exit 1; }
mkdir -p "$out"
echo "| stream | samples | bytes | test PSNR (dB) | evaluations per ray | multiply-accumulates per evaluation | Cortex-M4 instructions per ray (cost model) |"
echo "|---|---|---|---|---|---|---|"
run() { # name samples-label encode-options...
  local name=$1 label=$2
  shift 2
  if [ ! -s "$out/$name.render.log" ]; then
  "$cnerf" encode "$data" -o "$out/$name.cnrf" --lambda 0.1 --preset tiny --downscale 4 \
    --iters 2000 --every 40 --log-every 500 --threads 1 --seed 1 "$@" > "$out/$name.log" 2>&1
  "$cnerf" render "$out/$name.cnrf" --dataset "$data" --downscale 4 --every 40 \
    -o "$out/$name.render" > "$out/$name.render.log.tmp" 2>&1
  mv "$out/$name.render.log.tmp" "$out/$name.render.log"
  fi
  local psnr evals macs m4
  psnr=$(sed -n 's/^mean over .*: psnr \([0-9.]*\) dB.*/\1/p' "$out/$name.render.log")
  evals=$(sed -n 's/^network evaluations per ray: \([0-9.]*\) .*/\1/p' "$out/$name.render.log")
  macs=$(sed -n 's/^network multiply-accumulates per ray: [0-9]* (\([0-9]*\) per evaluation.*/\1/p' "$out/$name.render.log")
  m4=$(sed -n 's/^Cortex-M4 (cost model[^:]*: \([0-9]*\) instructions per ray.*/\1/p' "$out/$name.render.log")
  echo "| $name | $label | $(stat -c %s "$out/$name.cnrf") | $psnr | $evals | $macs | $m4 |"
}
[ "$baseline" = 1 ] && run two-networks "32 + 32"
for n in $coarse; do
  run "one-network-$n$tag" "$n + 0" --fine 0 --coarse "$n" ${extra[@]+"${extra[@]}"}
done
