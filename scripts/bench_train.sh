#!/usr/bin/env bash
# Training speed and quality beside the reference, in one run on this machine:
#   1. the public PyTorch NeRF (../shared/reference/nerf-pytorch/run.sh ITERS 4 small);
#   2. cnerf train on the same Lego at 100x100, preset small (4x128, 32+32 samples,
#      1024 rays, 500 centre-crop iterations), then cnerf eval on test views r_0, r_40, r_80,
#      r_120, r_160;
#   3. build-rel/tests/bench_step: the median step, its GFLOP/s and sgemm's at the same shape.
# Prints a table and writes OUT/bench_train.csv.
#   scripts/bench_train.sh [ITERS] [OUT] [-- extra cnerf train options]
set -euo pipefail
cd "$(dirname "$0")/.."
iters=${1:-1000}; out=${2:-out/bench}; shift $(( $# < 2 ? $# : 2 )); [ "${1:-}" = "--" ] && shift
extra=("$@")
data=$(cd ../shared/data/lego && pwd)
ref=../shared/reference/nerf-pytorch/run.sh
mkdir -p "$out"
# The reference's loader imports OpenCV, which its run.sh does not install.
dpkg -s python3-opencv > /dev/null 2>&1 || apt-get install -y -qq python3-opencv > /dev/null
cmake -S . -B build-rel -DCMAKE_BUILD_TYPE=Release > /dev/null
cmake --build build-rel -j"$(nproc)" > /dev/null

echo "bench_train: reference, $iters iterations" >&2
ref_out=$("$ref" "$iters" 4 small)
ref_line=$(grep '^FINAL' <<< "$ref_out") || { echo "bench_train: the reference failed: $ref_out" >&2; exit 1; }
echo "$ref_line" > "$out/reference.txt"
ref_spi=$(sed -n 's/.* s_per_it \([0-9.]*\).*/\1/p' <<< "$ref_line")
ref_psnr=$(sed -n 's/.* test_psnr \([0-9.]*\).*/\1/p' <<< "$ref_line")
ref_s=$(sed -n 's/.* train_s \([0-9.]*\).*/\1/p' <<< "$ref_line")

echo "bench_train: cnerf, $iters iterations ${extra[*]}" >&2
build-rel/cnerf train "$data" -o "$out/cnerf.ckpt" --preset small --iters "$iters" --downscale 4 \
  --log-every 100 "${extra[@]}" > "$out/cnerf_train.log"
build-rel/cnerf eval "$out/cnerf.ckpt" "$data" --downscale 4 --every 40 > "$out/cnerf_eval.log"
our_s=$(sed -n 's/^saved .*: \([0-9.]*\) s, \([0-9.]*\) s\/it.*/\1/p' "$out/cnerf_train.log")
our_spi=$(sed -n 's/^saved .*: \([0-9.]*\) s, \([0-9.]*\) s\/it.*/\2/p' "$out/cnerf_train.log")
our_psnr=$(sed -n 's/^mean over .* psnr \([0-9.]*\) dB.*/\1/p' "$out/cnerf_eval.log")

echo "bench_train: bench_step" >&2
step=$(build-rel/tests/bench_step small 1024 9)
echo "$step" > "$out/bench_step.txt"

ratio=$(awk -v a="$our_s" -v b="$ref_s" 'BEGIN { printf "%.3f", a / b }')
{
  echo "system,iterations,train_seconds,seconds_per_iteration,test_psnr_db"
  echo "nerf-pytorch,$iters,$ref_s,$ref_spi,$ref_psnr"
  echo "cnerf,$iters,$our_s,$our_spi,$our_psnr"
} > "$out/bench_train.csv"
echo
echo "| system | iterations | train time (s) | s / iteration | test PSNR (dB), r_0..r_160 |"
echo "|---|---|---|---|---|"
echo "| nerf-pytorch (PyTorch, 2 threads) | $iters | $ref_s | $ref_spi | $ref_psnr |"
echo "| cnerf train ${extra[*]} | $iters | $our_s | $our_spi | $our_psnr |"
echo
echo "cnerf / reference wall time: $ratio"
echo "$step"
