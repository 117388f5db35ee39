#!/usr/bin/env bash
# The GEMM libraries side by side at the trainer's shapes (tests/bench/gemm_backends.c):
# OpenBLAS (pthreads), BLIS (OpenMP) and oneDNN, each with 2 threads, for the row counts of
# a batch (1024 rays x 64 fine samples = 65536, and 16384 as when the occupancy grid keeps a
# quarter). Installs libblis-dev and libdnnl-dev if missing, builds build-rel, writes
# OUT/gemm.csv (default out/bench) and prints the per-network totals: each library's
# median over REPEATS (3) interleaved repeats of the median of RUNS (9) calls.
#   [REPEATS=N] scripts/bench_gemm.sh [OUT] [RUNS]
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
echo "repeat,library,product,rows,chunk,n_in,n_out,seconds,gflops" > "$csv"
# The libraries take turns, REPEATS times (default 3), so that a noisy neighbour hits all.
for rep in $(seq "${REPEATS:-3}"); do
  for rows in 65536 16384; do
    for lib in openblas blis dnnl; do
      build-rel/tests/bench_gemm_$lib "$rows" "$runs" | tail -n +2 | sed "s/^/$rep,/" >> "$csv"
    done
  done
done
echo "| library | rows | one network's products, median of repeats (s) | GFLOP/s |"
echo "|---|---|---|---|"
for rows in 65536 16384; do
  for lib in openblas blis onednn; do
    awk -F, -v l="$lib" -v r="$rows" '$2 == l && $3 == "network" && $4 == r { print $8, $9 }' "$csv" |
      sort -n | awk -v l="$lib" -v r="$rows" '{ s[NR] = $1; g[NR] = $2 }
        END { m = int((NR + 1) / 2); printf "| %s | %s | %.4f | %.1f |\n", l, r, s[m], g[m] }'
  done
done
echo "bench_gemm: wrote $csv" >&2
