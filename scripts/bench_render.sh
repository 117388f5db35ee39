#!/usr/bin/env bash
# Speed against error of the fixed-point renderer, for one stream and its dataset.
#
#   scripts/bench_render.sh STREAM DATASET OUTDIR [--downscale F] [--every N] [--cg-px PX]
#                           [--settings "NC NF TSTOP [noskip]; ..."] [--plot-only]
#
# For every knob setting (coarse samples, fine samples, early-termination threshold, and
# `noskip` to ignore the stream's occupancy grid in both renderers):
#   - `cnerf render --threads 1` on every N-th test view: median ms per megapixel of the
#     fixed-point decoder and of the float reference renderer of the same file (same run,
#     same thread count), PSNR against the ground truth; PSNR, largest difference and share
#     of pixels off by more than 2 against the float reference with the same sample counts;
#     network evaluations per ray;
#   - instructions per ray of cnerf_render_tile alone (valgrind --tool=callgrind with
#     --toggle-collect), on the first view's camera scaled down to PX x PX pixels (the whole
#     view, so rays that miss the object count as they do in a frame).
# Writes OUTDIR/render_speed.csv, OUTDIR/render_speed.md (a table) and OUTDIR/render_speed.png
# (gnuplot: PSNR against the ground truth over seconds per megapixel for both renderers, and
# the fixed-point decoder's PSNR against the float reference over instructions per ray).
# Builds build/ first. --plot-only redraws the table and chart from an existing CSV.
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 3 ] || { sed -n '2,18p' "$0"; exit 2; }
stream=$1 data=$2 out=$3
shift 3
downscale=4 every=40 cgpx=20 settings="" plot_only=0
while [ $# -gt 0 ]; do
  case $1 in
    --downscale) downscale=$2; shift 2 ;;
    --every) every=$2; shift 2 ;;
    --cg-px) cgpx=$2; shift 2 ;;
    --settings) settings=$2; shift 2 ;;
    --plot-only) plot_only=1; shift ;;
    *) echo "bench_render.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
for tool in valgrind gnuplot python3; do
  command -v $tool > /dev/null || { echo "bench_render.sh: needs $tool (apt-get install valgrind gnuplot-nox python3)" >&2; exit 1; }
done
csv=$out/render_speed.csv
if [ $plot_only -eq 0 ]; then
[ -f "$stream" ] || { echo "bench_render.sh: $stream: no such file" >&2; exit 1; }
cmake -S . -B build -DCMAKE_BUILD_TYPE=RelWithDebInfo > /dev/null
cmake --build build -j"$(nproc)" --target cnerf render_tile > /dev/null
mkdir -p "$out"
cnerf=build/cnerf

read -r NC NF < <(./build/cnerf info --no-estimate "$stream" | sed -n 's/^samples: \([0-9]*\) coarse + \([0-9]*\) fine$/\1 \2/p')
[ -n "${NC:-}" ] || { echo "bench_render.sh: cannot read the sample counts of $stream" >&2; exit 1; }
if [ -z "$settings" ]; then
  h=$((NF / 2)) q=$((NF / 4)) c=$((NC / 2))
  settings="$NC $NF 0; $NC $NF 0.000244140625; $NC $NF 0.0009765625; $NC $NF 0.00390625;"
  settings+=" $NC $NF 0.015625; $NC $h 0.000244140625; $NC $q 0.000244140625;"
  settings+=" $c $h 0.000244140625"
  # the coarse network's image alone, when the stream carries its colour
  coarse_color=1
  grep -q "^network 0 (coarse):.*no colour" <<< "$(./build/cnerf info --no-estimate "$stream")" && coarse_color=0
  [ $coarse_color -eq 1 ] && settings+="; $NC 0 0.000244140625; $c 0 0.000244140625"
  # a stream with an occupancy grid: the main settings again without it
  if grep -q "^occupancy grid: [0-9]" <<< "$(./build/cnerf info --no-estimate "$stream")"; then
    settings+="; $NC $NF 0.000244140625 noskip; $NC $h 0.000244140625 noskip"
    [ $coarse_color -eq 1 ] && settings+="; $NC 0 0.000244140625 noskip"
  fi
fi

echo "n_coarse,n_fine,t_stop,instr_per_ray,ms_per_mp,float_ms_per_mp,speed_ratio,psnr_gt,float_psnr_gt,psnr_vs_float,max_diff,pct_px_over2,grid,evals_per_ray" > "$csv"
IFS=';' read -ra rows <<< "$settings"
n=${#rows[@]} k=0
for row in "${rows[@]}"; do
  read -r nc nf ts skip <<< "$row"
  k=$((k + 1))
  noskip=() flags=0
  [ "${skip:-}" = noskip ] && noskip=(--no-skip) flags=1
  echo "[$k/$n] $nc coarse + $nf fine samples, t_stop $ts ${skip:-}" >&2
  log=$out/render_${nc}_${nf}_${ts}${skip:+_$skip}.log
  $cnerf render "$stream" --dataset "$data" --downscale "$downscale" --every "$every" \
    --threads 1 --coarse "$nc" --fine "$nf" --t-stop "$ts" --save-cameras "$out/cameras.txt" \
    "${noskip[@]}" > "$log"
  # The first view's camera, scaled down to cgpx x cgpx, for callgrind.
  python3 - "$out/cameras.txt" "$cgpx" > "$out/cam_cg.txt" <<'PY'
import sys
v = open(sys.argv[1]).readline().split()
px = int(sys.argv[2]); w, h = int(v[16]), int(v[17]); s = px / max(w, h)
ints = [int(x) for x in v[:16]]
for i in (12, 13, 14, 15):
    ints[i] = round(ints[i] * s)
print(*ints, max(1, round(w * s)), max(1, round(h * s)))
PY
  read -r cw chh < <(awk '{print $17, $18}' "$out/cam_cg.txt")
  valgrind --tool=callgrind --toggle-collect=cnerf_render_tile \
    --callgrind-out-file="$out/callgrind.out" build/tests/render_tile "$stream" "$out/cam_cg.txt" \
    0 0 "$cw" "$chh" "$nc" "$nf" "$(python3 -c "print(round($ts * 2**30))")" "$flags" > /dev/null \
    2> "$out/callgrind.err"
  ir=$(sed -n 's/^totals: *\([0-9]*\).*/\1/p' "$out/callgrind.out")
  python3 - "$log" "$nc" "$nf" "$ts" "$ir" "$((cw * chh))" "${skip:-}" >> "$csv" <<'PY'
import re, statistics, sys
log, nc, nf, ts, ir, rays, skip = sys.argv[1:]
ms, fms, px, ev, grid = [], [], None, "", "none"
for line in open(log):
    m = re.match(r"network evaluations per ray: ([0-9.]+) \(([0-9.]+) without skipping(.*)\)", line)
    if m:
        ev = m.group(1)
        grid = "none" if "no occupancy grid" in m.group(3) else ("ignored" if skip else "used")
for line in open(log):
    m = re.search(r"psnr .*?([0-9.]+) ms  float +([0-9.]+) ms", line)
    if m:
        ms.append(float(m.group(1))); fms.append(float(m.group(2)))
    m = re.match(r"mean over .*psnr ([0-9.]+) dB .*float reference ([0-9.]+) dB\)  vs float (identical|([0-9.]+) dB).*max diff (\d+) \((\d+) of (\d+) px > 2\)", line)
    if m:
        g, fg, vs, md = m.group(1), m.group(2), m.group(4) or "inf", m.group(5)
        over2 = 100.0 * int(m.group(6)) / int(m.group(7))
size = open(sys.argv[1].rsplit("/", 1)[0] + "/cameras.txt").readline().split()[16:18]
mp = int(size[0]) * int(size[1]) / 1e6
a, b = statistics.median(ms) / mp, statistics.median(fms) / mp
print(f"{nc},{nf},{ts},{int(ir) / int(rays):.0f},{a:.1f},{b:.1f},{a / b:.3f},{g},{fg},{vs},{md},{over2:.3f},{grid},{ev}")
PY
done
rm -f "$out/callgrind.out" "$out/callgrind.err" "$out/cam_cg.txt"
fi
[ -f "$csv" ] || { echo "bench_render.sh: no $csv to plot" >&2; exit 1; }

python3 - "$csv" > "$out/render_speed.md" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
grid = any(r.get("grid") for r in rows)
print("| coarse + fine | t_stop |" + (" grid | evaluations / ray |" if grid else "") + " instructions / ray | ms / MP | float ref. ms / MP | fixed / float time | PSNR vs truth | float ref. vs truth | fixed vs float ref. | max diff | px > 2 |")
print("|---|---|" + ("---|---|" if grid else "") + "---|---|---|---|---|---|---|---|---|")
for r in rows:
    ts = float(r["t_stop"]); tss = "0" if ts == 0 else f"1/{round(1 / ts)}"
    g = f" {r.get('grid', '')} | {r.get('evals_per_ray', '')} |" if grid else ""
    print(f"| {r['n_coarse']} + {r['n_fine']} | {tss} |{g} {int(r['instr_per_ray']):,} | {float(r['ms_per_mp']):,.0f} | "
          f"{float(r['float_ms_per_mp']):,.0f} | {float(r['speed_ratio']):.2f} | {r['psnr_gt']} dB | {r['float_psnr_gt']} dB | "
          f"{r['psnr_vs_float']} dB | {r['max_diff']} | {r['pct_px_over2']}% |")
PY
cat "$out/render_speed.md"

gnuplot <<GP
set terminal pngcairo size 1200,520 font ",10"
set output "$out/render_speed.png"
set datafile separator ","
set multiplot layout 1,2 title "Fixed-point decoder, speed against error ($(basename "$stream"), 1 thread)"
set grid
set logscale x
set key bottom right
lbl(c) = sprintf("%s+%s", stringcolumn(1), stringcolumn(2))
set title "PSNR against the ground truth (default early termination)"
set xlabel "seconds per megapixel (median over the views)"
set ylabel "test PSNR (dB)"
main(x) = (\$3 == 0.000244140625 && strcol(13) ne "ignored") ? x : NaN
plot "$csv" every ::1 using (main(\$5 / 1000)):8:(lbl(0)) with labels offset 0,0.8 font ",8" notitle, \
     "$csv" every ::1 using (main(\$5 / 1000)):8 with points pt 7 ps 1.2 title "fixed-point decoder", \
     "$csv" every ::1 using (main(\$6 / 1000)):9 with points pt 6 ps 1.2 title "float reference renderer"
set title "Error against the float reference (all settings)"
set xlabel "instructions per ray (callgrind)"
set ylabel "PSNR against the float reference (dB)"
unset key
plot "$csv" every ::1 using 4:10:(sprintf("%s %s%s", lbl(0), \$3 == 0 ? "exact" : sprintf("1/%.0f", 1 / \$3), strcol(13) eq "ignored" ? " no grid" : "")) with labels offset 0,0.8 font ",8", \
     "$csv" every ::1 using 4:10 with points pt 7 ps 1.2
unset multiplot
GP
echo "wrote $csv, $out/render_speed.md, $out/render_speed.png" >&2
