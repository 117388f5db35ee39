#!/usr/bin/env bash
# The GEMM libraries side by side at the trainer's shapes (tests/bench/gemm_backends.c):
# OpenBLAS (pthreads), BLIS (OpenMP) and oneDNN, each with 2 threads, for the row counts of
# a batch (1024 rays x 64 fine samples = 65536, and 16384 as when the occupancy grid keeps a
# quarter). Installs libblis-dev and libdnnl-dev if missing, builds build-rel, writes
# OUT/gemm.csv (default out/bench) and prints the per-network totals.
#   scripts/bench_gemm.sh [OUT] [RUNS]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/bench}; runs=${2:-9}
mkdir -p "$out"
for p in libblis-dev libdnnl-dev; do
  dpkg -s "$p" > /dev/null 2>&1 || apt-get install -y -qq "$p" > /dev/null
done
cmake -S . -B build-rel -DCMAKE_BUILD_TYPE=Release > /dev/null
cmake --build build-rel -j"$(nproc)" --target bench_gemm_openblas bench_gemm_blis bench_gemm_dnnl > /dev/null
export OMP_NUM_THREADS=2 OPENBLAS_NUM_THREADS=2 BLIS_NUM_THREADS=2
csv=$out/gemm.csv
echo "library,product,rows,n_in,n_out,seconds,gflops" > "$csv"
for rows in 65536 16384; do
  for lib in openblas blis dnnl; do
    build-rel/tests/bench_gemm_$lib "$rows" "$runs" | tail -n +2 >> "$csv"
  done
done
echo "| library | rows | one network's products (s) | GFLOP/s |"
echo "|---|---|---|---|"
awk -F, '$2 == "network" { printf "| %s | %s | %.4f | %.1f |\n", $1, $3, $6, $7 }' "$csv"
echo "bench_gemm: wrote $csv" >&2
