#!/usr/bin/env bash
# The WebAssembly decoder against the native one, on this machine, in one run:
#   experiments/web_bench.sh OUT [MAIN.cnrf [SMALL.cnrf]] [--runs N] [--rounds R] [--sizes "100 400"]
# MAIN: the README main job's stream (default out/lego.cnrf, which scripts/demo.sh writes);
# SMALL: a stream of preset small (default: encoded here, the main job's command with
# --preset small and 500 iterations). For each, the first `cnerf render --orbit` camera at
# each size (100x100 and 400x400 by default): the median of N renders (default 5) by
# `cnerf render --threads 1` and `--threads 2` with `--no-reference` (its ms/frame: the fixed-point render
# alone), and by the JavaScript package with 1
# and 2 workers under Node and in headless Chromium (experiments/web_bench.mjs: the render
# calls only). Writes OUT/bench.csv and OUT/bench.md; needs build/web (the build makes it when
# clang and wasm-ld are there), node and chromium.
# --rounds R (default 1) measures all of it R times in turn, native then Node then Chromium,
# so that a machine whose speed drifts slows each side alike: the table gives the median over
# the rounds of each time, and of each round's ratio (bench.csv has a row per round).
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: experiments/web_bench.sh OUT [MAIN.cnrf [SMALL.cnrf]] [--runs N]}
shift
runs=5
rounds=1
sizes="100 400"
streams=()
while [ $# -gt 0 ]; do
  case $1 in
    --runs) runs=$2; shift 2 ;;
    --rounds) rounds=$2; shift 2 ;;
    --sizes) sizes=$2; shift 2 ;;
    *) streams+=("$1"); shift ;;
  esac
done
cnerf=./build/cnerf
data=${CNERF_DATA:-../shared/data}
mkdir -p "$out"
main=${streams[0]:-out/lego.cnrf}
[ -f "$main" ] || { echo "web_bench.sh: $main is missing (scripts/demo.sh writes it)" >&2; exit 1; }
small=${streams[1]:-$out/small.cnrf}
if [ ! -f "$small" ]; then
  "$cnerf" encode "$data/lego" -o "$small" --lambda 0.1 --preset small --downscale 4 --iters 500 \
    --every 40 --log-every 100 > "$out/small-encode.log"
fi
median() { sort -n | awk '{a[NR] = $1} END {print a[int((NR + 1) / 2)]}'; }
echo "where,name,camera,width,workers,median_ms,evals_per_ray,memory_per_worker,round" > "$out/bench.csv"
specs=()
for pair in "main=$main" "small=$small"; do
  name=${pair%%=*} s=${pair#*=}
  : > "$out/$name.cams"
  for size in $sizes; do
    "$cnerf" render "$s" --orbit 1 --size $size --no-reference -o "$out/r-$name-$size" \
      --save-cameras "$out/$name-$size.cam" > /dev/null
    cat "$out/$name-$size.cam" >> "$out/$name.cams"
  done
  specs+=("$name=$s:$out/$name.cams")
done
for round in $(seq "$rounds"); do
for pair in "main=$main" "small=$small"; do
  name=${pair%%=*} s=${pair#*=}
  for size in $sizes; do
    for t in 1 2; do
      ms=$(for r in $(seq "$runs"); do
             "$cnerf" render "$s" --orbit 1 --size $size --threads $t --no-reference \
               -o "$out/r-$name-$size" | sed -n 's/.* \([0-9.]*\) ms\/frame$/\1/p'
           done | median)
      epr=$("$cnerf" render "$s" --orbit 1 --size $size --no-reference -o "$out/r-$name-$size" |
              sed -n 's/^network evaluations per ray: \([0-9.]*\).*/\1/p')
      echo "native,$name,orbit_000,$size,$t,$ms,$epr,,$round" >> "$out/bench.csv"
    done
  done
done
node experiments/web_bench.mjs build/web "$runs" "${specs[@]}" | sed "s/\$/,$round/" >> "$out/bench.csv"
done
python3 - "$out/bench.csv" > "$out/bench.md" <<'PY'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
rounds = sorted({r["round"] for r in rows}, key=int)
get = lambda w, n, s, k, q: next(float(r["median_ms"]) for r in rows if (r["where"], r["name"], r["width"], r["workers"], r["round"]) == (w, n, s, k, q))
med = lambda xs: statistics.median(xs)
mem = {r["name"]: int(r["memory_per_worker"]) for r in rows if r["where"] == "chromium"}
if len(rounds) > 1:
    print(f"Medians over {len(rounds)} rounds (times, and each round's Chromium / native).")
    print()
print("| stream | size | threads / workers | native (ms) | Node (ms) | Chromium (ms) | Chromium / native |")
print("|---|---|---|---|---|---|---|")
for n in ("main", "small"):
    for s in sorted({r["width"] for r in rows}, key=int):
        for k in ("1", "2"):
            a, b, c = ([get(w, n, s, k, q) for q in rounds] for w in ("native", "node", "chromium"))
            ratio = med([y / x for x, y in zip(a, c)])
            print(f"| {n} | {s}×{s} | {k} | {med(a):.1f} | {med(b):.1f} | {med(c):.1f} | {ratio:.2f} |")
print()
print("WebAssembly memory per worker: " + ", ".join(f"{n} {m:,} bytes" for n, m in mem.items()))
PY
# sizes: the module, the package's script, the single file of the main stream, gzipped too
"$cnerf" html "$main" -o "$out/main.html" > /dev/null
{
  echo
  echo "| file | bytes | gzipped (-9) |"
  echo "|---|---|---|"
  for f in build/web/cnerf.wasm build/web/cnerf-bundle.js "$out/main.html"; do
    echo "| $(basename "$f") | $(stat -c %s "$f") | $(gzip -9c "$f" | wc -c) |"
  done
} >> "$out/bench.md"
cat "$out/bench.md"
