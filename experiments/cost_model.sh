#!/usr/bin/env bash
# The receiver's cost model: renders up to three tiles of every valid conformance vector
# (the first lines of its .md5, with their sample counts and t_stop) with the firmware of the
# core FW_CORE names (m4 by default; m0plus, m7, m33, m55: scripts/firmware.sh) under QEMU, in
# batches (scripts/firmware.sh --jobs: instructions of cnerf_render_tile, and the work the
# firmware counts, cnerf_render_stats), then fits the instructions of a tile as a sum of the
# work's terms, each with its coefficient (the columns of OUT.csv: multiply-accumulates of
# packed layers over int16 latents and over int8 latents, non-zero latents multiplied in list layers, multiply-accumulates in int64,
# layer inputs and outputs, exact rescales, network evaluations, positional-encoding values,
# sample positions, sample positions of contracted streams, samples placed, rays of NDC
# streams, rays, tiles) by least squares on the relative error. Prints the coefficients and
# each tile's error. The coefficients go into platform/host/cost_model.c, whose terms are
# these, in this order.
#   experiments/cost_model.sh OUT          measure (OUT.csv), then fit
#   experiments/cost_model.sh --fit OUT    fit OUT.csv again
set -euo pipefail
cd "$(dirname "$0")/.."
fit_only=0
[ "${1:-}" = --fit ] && { fit_only=1; shift; }
[ $# -eq 1 ] || { sed -n '2,16p' "$0" >&2; exit 2; }
out=$1
core=${FW_CORE:-${FW_BOARD:-m4}}
bdir=${FW_BUILD_DIR:-build-fw-cost-$core}
case $core in m55|an547) budget=350000 ;; *) budget=3000000 ;; esac
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
if [ $fit_only = 0 ]; then
  echo "tile,instructions,packed_macs,packed_s8_macs,list_nz,wide_macs,layer_values,exact_rescales,evals,pe_values,samples,contract_samples,placed,ndc_rays,rays,tiles" > "$out.csv"
  batch=0 bytes=0
  for md5 in vectors/valid/*.md5; do
    name=$(basename "$md5" .md5)
    case $name in *.s[0-9]*) continue ;; esac
    size=$(stat -c %s "vectors/valid/$name.cnrf")
    if [ $bytes -gt 0 ] && [ $((bytes + size)) -gt $budget ]; then
      batch=$((batch + 1)) bytes=0
    fi
    bytes=$((bytes + size))
    while read -r line cam x0 y0 w h nc nf ts _; do
      echo "$name:$line - $PWD/vectors/valid/$name.cnrf 0 $PWD/vectors/valid/$name.cam $cam $x0 $y0 $w $h $nc $nf $ts" \
        >> "$work/batch$batch.jobs"
    done < <(head -n 3 "$md5" | nl -ba -w1 -s' ')
  done
  for jobs in "$work"/batch*.jobs; do
    if ! res=$(FW_CORE=$core FW_BUILD_DIR=$bdir FW_TIMEOUT=6000 scripts/firmware.sh --jobs "$jobs" \
                 < /dev/null 2>&1); then
      echo "$res" | tail -n 20 >&2
      echo "cost_model: the firmware failed on $jobs" >&2
      exit 1
    fi
    RES=$res python3 - "$out.csv" <<'PY'
import os, re, sys
name = None
with open(sys.argv[1], "a") as f:
    for line in os.environ["RES"].splitlines():
        m = re.match(r"(\S+:\d+): [0-9a-f]{32}, ", line)
        if m:
            name = m.group(1)
        m = re.match(r"  work of the tile: (.*)$", line)
        if m and name:
            k = dict(zip(m.group(1).split()[0::2], map(int, m.group(1).split()[1::2])))
            row = [k["instructions"], k["macs"] - k["list_macs"] - k["wide_macs"] - k["s8_macs"],
                   k["s8_macs"], k["list_nz"],
                   k["wide_macs"], k["layer_values"], k["exact_rescales"], k["evals"],
                   k["evals"] * k["in_pos"], k["samples"], k["samples"] * k["contract"],
                   k["rays"] * k["samples_per_ray"], k["rays"] * k["ndc"], k["rays"], 1]
            f.write(name + "," + ",".join(map(str, row)) + "\n")
            name = None
PY
    echo "$(basename "$jobs"): done" >&2
  done
fi
python3 - "$out.csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
names = [k for k in rows[0] if k not in ("tile", "instructions")]
X = [[float(r[k]) for k in names] for r in rows]
y = [float(r["instructions"]) for r in rows]
n = len(names)
# least squares on the relative error: each row divided by its measured count
A = [[sum(X[i][p] * X[i][q] / y[i] ** 2 for i in range(len(X))) for q in range(n)] for p in range(n)]
b = [sum(X[i][p] / y[i] for i in range(len(X))) for p in range(n)]
for c in range(n):  # Gauss-Jordan elimination with partial pivoting
    piv = max(range(c, n), key=lambda r: abs(A[r][c]))
    A[c], A[piv], b[c], b[piv] = A[piv], A[c], b[piv], b[c]
    for r in range(n):
        if r != c and A[c][c]:
            f = A[r][c] / A[c][c]
            A[r] = [A[r][k] - f * A[c][k] for k in range(n)]
            b[r] -= f * b[c]
coef = [b[c] / A[c][c] if A[c][c] else 0.0 for c in range(n)]
print("coefficients: " + ", ".join(f"{k} {v:.4f}" for k, v in zip(names, coef)))
print("for cost_model.c: {" + ", ".join(f"{v:.4g}" for v in coef) + "}")
errs = []
for r, x, m in zip(rows, X, y):
    p = sum(c * v for c, v in zip(coef, x))
    errs.append(abs(p / m - 1))
    print(f"{r['tile']}: measured {m:.0f}, model {p:.0f} ({100 * (p / m - 1):+.1f}%)")
e = sorted(errs)
print(f"median error {100 * e[len(e) // 2]:.1f}%, 90% of the tiles within "
      f"{100 * e[int(0.9 * (len(e) - 1))]:.1f}%, largest error {100 * e[-1]:.1f}% over "
      f"{len(rows)} tiles")
PY
