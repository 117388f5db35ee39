#!/usr/bin/env bash
# What rounding alone costs with one quantization step per layer (what the stream's affine
# decoder expresses) against one step per output row (what it does not): a float model's
# kernels rounded to C times the RMS of their layer or row, for each C, each scored with
# `cnerf eval`. Nothing is trained.
#   experiments/round_steps.sh OUT FLOAT.ckpt DATASET "C..." [-- EVAL OPTIONS]
# The eval options default to "--downscale 4 --every 40 --threads 2". Bytes are the
# integers' empirical entropy, one distribution per layer (tables not counted), plus two
# bytes per row for the per-row steps (experiments/tools/round_steps.c). A run whose log is
# complete is not run again. Writes OUT/round_steps.csv and OUT/round_steps.md.
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 4 ] || { echo "usage: experiments/round_steps.sh OUT FLOAT.ckpt DATASET \"C...\" [-- EVAL OPTIONS]" >&2; exit 2; }
out=$1; ckpt=$2; data=$3; cs=$4; shift 4
[ $# -gt 0 ] && [ "$1" = "--" ] && shift
opts=("$@")
[ ${#opts[@]} -gt 0 ] || opts=(--downscale 4 --every 40 --threads 2)
cnerf=${CNERF:-build/cnerf}
tool=${ROUND_STEPS:-build/tests/round_steps}
[ -x "$cnerf" ] && [ -x "$tool" ] || { echo "round_steps.sh: build first (scripts/test.sh)" >&2; exit 1; }
[ -r "$ckpt" ] || { echo "round_steps.sh: $ckpt: no such checkpoint" >&2; exit 1; }
mkdir -p "$out"
psnr() { awk '/^mean over/ { for (i = 1; i <= NF; i++) if ($i == "psnr") p = $(i + 1) } END { print p }' "$1"; }
log=$out/float.log
grep -q '^mean over' "$log" 2> /dev/null || "$cnerf" eval "$ckpt" "$data" "${opts[@]}" > "$log" 2>&1
csv=$out/round_steps.csv
echo "scheme,c,latent_bytes,step_bytes,total_bytes,test_psnr_db" > "$csv"
echo "float,,,,,$(psnr "$log")" >> "$csv"
for scheme in layer row; do
  for c in $cs; do
    log=$out/$scheme-$c.log
    if ! grep -q '^mean over' "$log" 2> /dev/null; then
      echo "round_steps.sh: $scheme, c = $c" >&2
      "$tool" "$ckpt" "$out/$scheme-$c.ckpt" "$scheme" "$c" > "$out/$scheme-$c.bytes"
      "$cnerf" eval "$out/$scheme-$c.ckpt" "$data" "${opts[@]}" > "$log" 2>&1
      rm -f "$out/$scheme-$c.ckpt"
    fi
    read -r _ _ lb sb tb < "$out/$scheme-$c.bytes"
    echo "$scheme,$c,$lb,$sb,$tb,$(psnr "$log")" >> "$csv"
  done
done
{
  echo "| step | C | latents (bytes) | steps (bytes) | total (bytes) | test PSNR (dB) |"
  echo "|---|---|---|---|---|---|"
  tail -n +2 "$csv" | awk -F, '{ printf "| %s | %s | %s | %s | %s | %s |\n", $1 == "float" ? "none (float32)" : "per " $1, $2, $3, $4, $5, $6 }'
} > "$out/round_steps.md"
cat "$out/round_steps.md"
