#!/usr/bin/env bash
# Training speed and quality beside the reference, in one run on this machine:
#   1. the public PyTorch NeRF (../shared/reference/nerf-pytorch/run.sh ITERS 4 small);
#   2. cnerf train on the same Lego at 100x100, preset small (4x128, 32+32 samples,
#      1024 rays, 500 centre-crop iterations), then cnerf eval on test views r_0, r_40, r_80,
#      r_120, r_160; with `-- OPTIONS`, a second cnerf run with those train options too;
#   3. bench_step: the median step on synthetic rays, its GFLOP/s and the GEMM's at the same
#      shape, for the default build (oneDNN) and an OpenBLAS build (-DCNERF_GEMM=openblas).
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
cmake -S . -B build-rel-openblas -DCMAKE_BUILD_TYPE=Release -DCNERF_GEMM=openblas > /dev/null
cmake --build build-rel-openblas -j"$(nproc)" --target bench_step > /dev/null

echo "bench_train: reference, $iters iterations" >&2
ref_out=$("$ref" "$iters" 4 small)
ref_line=$(grep '^FINAL' <<< "$ref_out") || { echo "bench_train: the reference failed: $ref_out" >&2; exit 1; }
echo "$ref_line" > "$out/reference.txt"
ref_spi=$(sed -n 's/.* s_per_it \([0-9.]*\).*/\1/p' <<< "$ref_line")
ref_psnr=$(sed -n 's/.* test_psnr \([0-9.]*\).*/\1/p' <<< "$ref_line")
ref_s=$(sed -n 's/.* train_s \([0-9.]*\).*/\1/p' <<< "$ref_line")

csv=$out/bench_train.csv
echo "system,options,iterations,train_seconds,seconds_per_iteration,test_psnr_db,ratio_to_reference" > "$csv"
echo "nerf-pytorch,,$iters,$ref_s,$ref_spi,$ref_psnr,1" >> "$csv"
table="| nerf-pytorch (PyTorch, 2 threads) | $iters | $ref_s | $ref_spi | $ref_psnr | 1 |"
run_cnerf() { # name, train options...
  local name=$1; shift
  echo "bench_train: cnerf $*, $iters iterations" >&2
  # The reference's learning rate and decay (cnerf's defaults are 5e-3 over the run).
  build-rel/cnerf train "$data" -o "$out/$name.ckpt" --force --preset small --iters "$iters" --downscale 4 \
    --lr 5e-4 --lr-decay 500000 --log-every 100 "$@" > "$out/${name}_train.log"
  build-rel/cnerf eval "$out/$name.ckpt" "$data" --downscale 4 --every 40 > "$out/${name}_eval.log"
  local s spi psnr ratio
  s=$(sed -n 's/^saved .*: \([0-9.]*\) s, \([0-9.]*\) s\/it.*/\1/p' "$out/${name}_train.log")
  spi=$(sed -n 's/^saved .*: \([0-9.]*\) s, \([0-9.]*\) s\/it.*/\2/p' "$out/${name}_train.log")
  psnr=$(sed -n 's/^mean over .* psnr \([0-9.]*\) dB.*/\1/p' "$out/${name}_eval.log")
  ratio=$(awk -v a="$s" -v b="$ref_s" 'BEGIN { printf "%.3f", a / b }')
  echo "cnerf,$*,$iters,$s,$spi,$psnr,$ratio" >> "$csv"
  table+=$'\n'"| cnerf train $* | $iters | $s | $spi | $psnr | $ratio |"
}
run_cnerf cnerf
[ ${#extra[@]} -gt 0 ] && run_cnerf cnerf_extra "${extra[@]}"

echo "bench_train: bench_step" >&2
{
  build-rel/tests/bench_step small 1024 9
  build-rel-openblas/tests/bench_step small 1024 9
} > "$out/bench_step.txt"

echo
echo "| system | iterations | train time (s) | s / iteration | test PSNR (dB), r_0..r_160 | time / reference's |"
echo "|---|---|---|---|---|---|"
echo "$table"
echo
cat "$out/bench_step.txt"
