#!/usr/bin/env bash
# Rate-distortion sweep of one scene: cnerf encode at several lambdas, the same architecture
# trained without compression (float32, 4 bytes a parameter), and the naive baseline
# (post-training uniform quantization of that float model to B bits, coded with the same
# entropy coder). Writes OUT/rd.csv, OUT/rd.md (a table) and, with gnuplot, OUT/rd.png.
#   experiments/rd.sh DATASET OUT [--downscale F] [--iters N] [--preset P] [--every N]
#                 [--lambdas "L1 L2 ..."] [--sizes "S1 S2 ..."] [--bits "B1 B2 ..."]
#                 [--jobs J] [--lr X] [--lr-decay N]
#                 [--from-float "S1 S2 ..."] [--from-float-iters N] [--from-float-lr X]
# --sizes adds cnerf points encoded to a file size with rate control (--size S) instead of
# a lambda (--lambdas "" leaves the lambda sweep out). --from-float adds points encoded to
# a size from the float model (cnerf encode --init) in --from-float-iters more iterations
# (1/10 of --iters by default) at --from-float-lr (encode's default by default).
# (--lr and --lr-decay go to every training run; the tables in docs/results.md before the
# learning rate became 5e-3 over the run used --lr 5e-4 --lr-decay 500000.)
# Each run uses one thread when --jobs is 2 (two runs side by side), else every core.
# CNERF=path runs another cnerf binary than build/cnerf (a copy, so that rebuilding does
# not change a sweep midway).
set -euo pipefail
cd "$(dirname "$0")/.."
data=${1:?dataset directory}; out=${2:?output directory}; shift 2
downscale=4 iters=1000 preset=small every=40 jobs=1
lambdas="1e-3 1 3 5 10" sizes="" bits="4 5 6 8" lr=() ff_sizes="" ff_iters="" ff_lr=()
while [ $# -gt 0 ]; do
  case $1 in
    --downscale) downscale=$2 ;; --iters) iters=$2 ;; --preset) preset=$2 ;;
    --every) every=$2 ;; --lambdas) lambdas=$2 ;; --sizes) sizes=$2 ;; --bits) bits=$2 ;;
    --jobs) jobs=$2 ;;
    --from-float) ff_sizes=$2 ;; --from-float-iters) ff_iters=$2 ;; --from-float-lr) ff_lr=(--lr "$2") ;;
    --lr|--lr-decay) lr+=("$1" "$2") ;;
    *) echo "rd.sh: unknown option $1" >&2; exit 2 ;;
  esac
  shift 2
done
ff_iters=${ff_iters:-$((iters / 10))}
cnerf=${CNERF:-build/cnerf}
[ -x "$cnerf" ] || { echo "rd.sh: build first (scripts/test.sh or cmake --build build)" >&2; exit 1; }
mkdir -p "$out/log"
threads=$(( jobs > 1 ? 1 : $(nproc) ))
common=(--preset "$preset" --iters "$iters" --downscale "$downscale" --threads "$threads" ${lr[@]+"${lr[@]}"})

# The mean test PSNR / SSIM line that eval and encode print.
psnr_of() { sed -n 's/.*mean over .* psnr \([0-9.]*\) dB  ssim \([0-9.]*\).*/\1 \2/p; s/^test: .* psnr \([0-9.]*\) dB, ssim \([0-9.]*\),.*/\1 \2/p' "$1" | tail -1; }
bytes_of() { stat -c %s "$1"; }

# A finished run (its output and a PSNR line in its log) is kept, so an interrupted sweep
# picks up where it stopped; delete OUT to start over.
done_run() { [ -s "$1" ] && [ -n "$(psnr_of "$2")" ]; }

# run_encode NAME OPTION VALUE [MORE OPTIONS]: one cnerf point, OUT/NAME.cnrf.
run_encode() {
  local name=$1 opt=$2 val=$3
  shift 3
  if done_run "$out/$name.cnrf" "$out/log/$name.log"; then return 0; fi
  local start=("$@")  # an interrupted encode continues from its last checkpoint
  [ -s "$out/$name.cnrf.ckpt" ] && start=(--resume "$out/$name.cnrf.ckpt")
  $cnerf encode "$data" -o "$out/$name.cnrf" "$opt" "$val" "${common[@]}" --every "$every" \
    --log-every 250 "${start[@]}" >> "$out/log/$name.log" 2>&1 ||
    echo "rd.sh: $name: cnerf encode failed (see $out/log/$name.log)" >&2
  rm -f "$out/$name.cnrf.ckpt"
}
run_float() {
  if ! done_run "$out/float.ckpt" "$out/log/float.log"; then
    # an interrupted training continues from its checkpoint (train writes it to -o)
    local resume=()
    [ -s "$out/float.ckpt" ] && resume=(--resume)
    $cnerf train "$data" -o "$out/float.ckpt" "${common[@]}" --log-every 250 "${resume[@]}" \
      >> "$out/log/float.log" 2>&1
    $cnerf eval "$out/float.ckpt" "$data" --downscale "$downscale" --every "$every" \
      --threads "$threads" >> "$out/log/float.log" 2>&1
  fi
  for b in $bits; do
    if done_run "$out/q$b.cnrf" "$out/log/q$b.log"; then continue; fi
    $cnerf quantize "$out/float.ckpt" -o "$out/q$b.cnrf" --bits "$b" --coarse-color off > "$out/log/q$b.log" 2>&1
    $cnerf eval "$out/q$b.cnrf" "$data" --downscale "$downscale" --every "$every" \
      --threads "$threads" >> "$out/log/q$b.log" 2>&1
  done
}

# Jobs, J at a time: the float model (and its quantized copies) first, then the points from
# it (with --from-float the float model is waited for), then the lambdas and the sizes.
tasks=(float)
[ -n "$ff_sizes" ] && tasks+=(wait)
for b in $ff_sizes; do tasks+=("from-float:$b"); done
for l in $lambdas; do tasks+=("lambda:$l"); done
for b in $sizes; do tasks+=("size:$b"); done
running=0
for t in "${tasks[@]}"; do
  case $t in
    wait) wait; running=0; continue ;;
    float) run_float & ;;
    from-float:*) run_encode "from-float-${t#from-float:}" --size "${t#from-float:}" \
                    --init "$out/float.ckpt" --iters "$ff_iters" ${ff_lr[@]+"${ff_lr[@]}"} & ;;
    lambda:*) run_encode "lambda-${t#lambda:}" --lambda "${t#lambda:}" & ;;
    size:*) run_encode "size-${t#size:}" --size "${t#size:}" & ;;
  esac
  echo "rd.sh: started $t"
  running=$((running + 1))
  if [ $running -ge "$jobs" ]; then wait -n; running=$((running - 1)); fi
done
wait

csv=$out/rd.csv
echo "method,setting,bytes,psnr,ssim" > "$csv"
# float32's bytes: 4 per parameter of the model that train reports
params=$(sed -n 's/^model: .* \([0-9]*\) parameters$/\1/p' "$out/log/float.log" | head -1)
[ -n "$params" ] || { echo "rd.sh: no parameter count in $out/log/float.log" >&2; exit 1; }
read -r p s <<< "$(psnr_of "$out/log/float.log")"
echo "float32,,$((4 * params)),$p,$s" >> "$csv"
for b in $bits; do
  read -r p s <<< "$(psnr_of "$out/log/q$b.log")"
  echo "uniform,$b bits,$(bytes_of "$out/q$b.cnrf"),$p,$s" >> "$csv"
done
for l in $lambdas; do
  read -r p s <<< "$(psnr_of "$out/log/lambda-$l.log")"
  echo "cnerf,lambda $l,$(bytes_of "$out/lambda-$l.cnrf"),$p,$s" >> "$csv"
done
for b in $sizes; do
  read -r p s <<< "$(psnr_of "$out/log/size-$b.log")"
  echo "cnerf,size $b,$(bytes_of "$out/size-$b.cnrf"),$p,$s" >> "$csv"
done
for b in $ff_sizes; do
  read -r p s <<< "$(psnr_of "$out/log/from-float-$b.log")"
  echo "cnerf from float,size $b (+$ff_iters iterations),$(bytes_of "$out/from-float-$b.cnrf"),$p,$s" >> "$csv"
done
cat "$csv"
# The same as a table, with each file's size and PSNR against the float32 model's.
awk -F, 'NR == 2 { fb = $3; fp = $4 }
  NR == 1 { print "| method | setting | bytes | float32 size / size | test PSNR (dB) | vs float32 (dB) | SSIM |";
            print "|---|---|---|---|---|---|---|"; next }
  { printf "| %s | %s | %d | %.1f | %.2f | %+.2f | %.4f |\n", $1, $2, $3, fb / $3, $4, $4 - fp, $5 }' \
  "$csv" > "$out/rd.md"
cat "$out/rd.md"

if command -v gnuplot > /dev/null; then
  ff_plot=""
  [ -n "$ff_sizes" ] && ff_plot="\"< grep '^cnerf from float,' $csv | sort -t, -k3 -n\" using 3:4 with linespoints lw 2 pt 11 title \"cnerf from the float model (+$ff_iters iterations)\","
  gnuplot <<GP
set terminal pngcairo size 800,520 noenhanced
set output "$out/rd.png"
set datafile separator ","
set logscale x
set xlabel "file size (bytes)"
set ylabel "test PSNR (dB)"
set key bottom right
set grid
set title "$(basename "$data"), preset $preset, $iters iterations, downscale $downscale"
plot "< grep '^cnerf,' $csv | sort -t, -k3 -n" using 3:4 with linespoints lw 2 pt 7 title "cnerf", \
     $ff_plot \
     "< grep '^uniform,' $csv" using 3:4 with linespoints lw 2 pt 5 title "uniform quantization (4-8 bits) + same entropy coder", \
     "< grep '^float32,' $csv" using 3:4 with points pt 9 ps 2 title "float32"
GP
  echo "rd.sh: wrote $out/rd.png"
else
  echo "rd.sh: gnuplot not found (apt-get install gnuplot-nox): no chart" >&2
fi
