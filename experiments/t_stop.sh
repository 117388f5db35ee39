#!/usr/bin/env bash
# The renderer's transmittance cut-off t_stop against quality and compute, on one stream:
# for each t_stop, the test views' PSNR and network evaluations per ray (the host's
# fixed-point decoder, `cnerf render --t-stop`), and the instructions per ray of the first
# test view rendered whole by the Cortex-M4 firmware (scripts/firmware.sh, -Os, QEMU's
# counts; its MD5 checked against the host's). Prints markdown rows.
#   experiments/t_stop.sh STREAM DATASET [cnerf render options, e.g. --downscale 4]
# T_STOPS (default "0.000244140625 0.001 0.003 0.01 0.03": 2^-12, the default, and four
# larger) lists the values; CNERF the binary (build/cnerf).
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 2 ] || { sed -n '2,9p' "$0" >&2; exit 2; }
stream=$1 data=$2
shift 2
cnerf=${CNERF:-build/cnerf}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$cnerf" render "$stream" --dataset "$data" "$@" --every 1000000 \
  --save-cameras "$work/cam.txt" > /dev/null
read -r -a cam < <(head -n 1 "$work/cam.txt")
w=${cam[16]} h=${cam[17]} view=${cam[18]}
samples=$("$cnerf" info --no-estimate "$stream" | sed -n 's/^samples: \([0-9]*\) coarse + \([0-9]*\) fine.*/\1 \2/p')
echo "| t_stop | test PSNR (dB) | evaluations per ray | M4 instructions per ray, view $view ${w}x${h} |"
echo "|---|---|---|---|"
for t in ${T_STOPS:-0.000244140625 0.001 0.003 0.01 0.03}; do
  out=$("$cnerf" render "$stream" --dataset "$data" "$@" --t-stop "$t")
  psnr=$(sed -n 's/^mean over .* psnr \([0-9.]*\) dB .*/\1/p' <<<"$out")
  evals=$(sed -n 's/^network evaluations per ray: \([0-9.]*\).*/\1/p' <<<"$out")
  q30=$(python3 -c "print(round($t * 2**30))")
  fw=$(FW_TIMEOUT=6000 scripts/firmware.sh "$stream" "$work/cam.txt" "0 0 $w $h" $samples "$q30" 2>&1) ||
    { echo "$fw" >&2; exit 1; }
  ipr=$(sed -n 's/.*: \([0-9,]*\) instructions per ray.*/\1/p' <<<"$fw")
  echo "| $t | $psnr | $evals | $ipr |"
done
