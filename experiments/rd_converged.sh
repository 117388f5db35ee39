#!/usr/bin/env bash
# Rate-distortion at convergence, with the compress-the-views baseline, on one chart
# (docs/results.md, "At convergence"): the scene at preset small, 20,000 iterations,
# downscale 4 (options after -- replace these). experiments/rd.sh gives float32, uniform
# quantization of it, cnerf encoded to each of FROM_FLOAT sizes from the float model
# (encode --init, +1/10 of the iterations) and to each of SIZES from scratch (the same
# iterations as float32); experiments/hevc_views.sh gives the training views coded with HEVC
# at each QP and a NeRF trained on the decoded views by the receiver.
#   experiments/rd_converged.sh OUT [DATASET] [--from-float "S ..."] [--sizes "S ..."]
#                           [--qps "Q ..."] [--jobs J] [--no-run] [-- RUN OPTIONS]
# --no-run only assembles the table and chart from OUT/rd/rd.csv and OUT/hevc/hevc.csv.
# Writes OUT/converged.csv, OUT/converged.md and OUT/converged.png; OUT/rd and OUT/hevc
# hold the two sweeps. Both resume (finished runs are kept, interrupted trainings continue
# from their checkpoints); with --jobs 2 the two sweeps run side by side.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?output directory}; shift
data=../shared/data/lego
if [ $# -gt 0 ] && [ "${1#-}" = "$1" ]; then data=$1; shift; fi
ff="30000 45000 60000 90000 120000" sizes="" qps="38 30 22" jobs=1 sweep=1
run=(--preset small --downscale 4 --iters 20000 --every 40)
while [ $# -gt 0 ]; do
  case $1 in
    --from-float) ff=$2; shift 2 ;; --sizes) sizes=$2; shift 2 ;; --qps) qps=$2; shift 2 ;;
    --jobs) jobs=$2; shift 2 ;; --no-run) sweep=0; shift ;;
    --) shift; run=("$@"); break ;;
    *) echo "rd_converged.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
mkdir -p "$out"
if [ "$sweep" = 1 ]; then
  experiments/rd.sh "$data" "$out/rd" "${run[@]}" --lambdas "" --sizes "$sizes" --from-float "$ff" \
    > "$out/rd.out" 2>&1 &
  rd=$!
  [ "$jobs" -gt 1 ] || wait "$rd"
  experiments/hevc_views.sh "$out/hevc" "$data" "$qps" -- "${run[@]}" > "$out/hevc.out" 2>&1
  wait "$rd" || { echo "rd_converged.sh: rd.sh failed (see $out/rd.out)" >&2; exit 1; }
fi

csv=$out/converged.csv
echo "method,setting,bytes,test_psnr_db" > "$csv"
tail -n +2 "$out/rd/rd.csv" | cut -d, -f1-4 >> "$csv"
awk -F, 'NR > 1 && $1 != "uncoded" { printf "HEVC views + NeRF,QP %s,%s,%s\n", $1, $2, $4 }
         NR > 1 && $1 == "uncoded" { printf "uncoded 8-bit views + NeRF,,,%s\n", $4 }' \
  "$out/hevc/hevc.csv" >> "$csv"
awk -F, 'NR == 2 { fb = $3; fp = $4 }
  NR == 1 { print "| method | setting | bytes | float32 size / size | test PSNR (dB) | vs float32 (dB) |";
            print "|---|---|---|---|---|---|"; next }
  $3 == "" { printf "| %s | %s | – | – | %.2f | %+.2f |\n", $1, $2, $4, $4 - fp; next }
  { printf "| %s | %s | %d | %.1f | %.2f | %+.2f |\n", $1, $2, $3, fb / $3, $4, $4 - fp }' \
  "$csv" > "$out/converged.md"
cat "$out/converged.md"
if command -v gnuplot > /dev/null; then
  gnuplot <<GP
set terminal pngcairo size 860,540 noenhanced
set output "$out/converged.png"
set datafile separator ","
set logscale x
set xlabel "bytes sent to the receiver"
set ylabel "test PSNR (dB)"
set key bottom right
set grid
set title "$(basename "$data"), ${run[*]}"
plot "< grep '^cnerf from float,' $csv | sort -t, -k3 -n" using 3:4 with linespoints lw 2 pt 7 title "cnerf, from the float model", \
     "< grep '^cnerf,' $csv | sort -t, -k3 -n" using 3:4 with points pt 13 ps 1.6 title "cnerf, from scratch", \
     "< grep '^uniform,' $csv" using 3:4 with linespoints lw 2 pt 5 title "uniform quantization of float32", \
     "< grep '^float32,' $csv" using 3:4 with points pt 9 ps 2 title "float32", \
     "< grep '^HEVC' $csv | sort -t, -k3 -n" using 3:4 with linespoints lw 2 pt 4 lc rgb "#b22222" title "HEVC views (receiver trains a NeRF)"
GP
  echo "rd_converged.sh: wrote $out/converged.png"
fi
