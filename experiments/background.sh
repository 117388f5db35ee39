#!/usr/bin/env bash
# The background a 360-degree capture is encoded with: each capture encoded with the constant
# colour and with --background contract, the same options otherwise, and measured on its test
# views by the file's float reference (encode's own "test:" line). Prints a Markdown table:
# capture, transparency, forward-facing, and per background the file size and test PSNR.
#
#   experiments/background.sh OUT NAME=DIR [NAME=DIR ...]
#
# Environment: CNERF (build/cnerf), ITERS (1500), SIZE (160: --max-size), THREADS (1).
# Resumable: a finished encode (its log has a "test:" line) is not run again.
set -euo pipefail
cnerf=${CNERF:-build/cnerf} iters=${ITERS:-1500} size=${SIZE:-160} threads=${THREADS:-1}
out=$1
shift
mkdir -p "$out"
rows=""
for arg in "$@"; do
  name=${arg%%=*} dir=${arg#*=}
  cells=""
  for bg in constant contract; do
    f=$out/$name-$bg
    if ! grep -q "^test: " "$f.log" 2> /dev/null; then
      "$cnerf" encode "$dir" -o "$f.cnrf" --force --max-size "$size" --preset tiny --iters "$iters" \
        --quality 50 --threads "$threads" --background "$bg" --log-every 500 > "$f.log" 2>&1 ||
        { echo "background.sh: $name $bg failed (see $f.log)" >&2; exit 1; }
    fi
    psnr=$(sed -n 's/^test: .* psnr \([0-9.]*\) dB.*/\1/p' "$f.log")
    bytes=$(stat -c %s "$f.cnrf")
    cells+=" $bytes B, $psnr dB |"
  done
  transp=$(sed -n 's/^random backgrounds: \([0-9]* of [0-9]*\) training views have transparency.*/\1/p' "$out/$name-constant.log")
  ndc=no
  grep -q "forward-facing\|NDC" "$out/$name-constant.log" && ndc=yes
  rows+="| $name | ${transp:-none} | $ndc |$cells"$'\n'
done
echo "| capture | views with transparency | forward-facing | constant colour | contracted |"
echo "|---|---|---|---|---|"
printf '%s' "$rows"
