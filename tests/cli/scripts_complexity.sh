#!/usr/bin/env bash
# experiments/complexity.sh on the shared Lego at 16 pixels for a few iterations, one stream,
# with BEFORE set to this tree (both firmware paths run): its row (bytes of the file, PSNR,
# MACs and evaluations per ray, M4 instructions per ray after and before), the markdown table
# from it, and a second run that keeps the finished row.
set -euo pipefail
cnerf=$1 data=$2 work=$3 src=$4
rm -rf "$work" && mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }
export CNERF=$cnerf CONFIGS="tiny:tiny:0:6000" BEFORE=$src
bash "$src/experiments/complexity.sh" "$work/out" lego="$data/lego@100" --iters 20 \
  --max-size 16 --threads 1 > "$work/a.out" 2>&1 || fail "complexity.sh failed: $(tail -n 20 "$work/a.out")"
csv=$work/out/complexity.csv
[ "$(wc -l < "$csv")" -eq 2 ] || fail "rows: $(cat "$csv")"
IFS=, read -r scene cfg preset mu target bytes psnr psnr_b view w h macs evals ipr ipr_b < <(tail -n 1 "$csv")
[ "$scene,$cfg,$preset,$mu,$target" = "lego,tiny,tiny,0,6000" ] || fail "row key: $(tail -n 1 "$csv")"
[ "$bytes" = "$(stat -c %s "$work/out/files/lego-tiny-6000.cnrf")" ] || fail "bytes $bytes are not the file's"
[[ $psnr =~ ^[0-9]+\.[0-9]+$ && $psnr_b =~ ^[0-9]+\.[0-9]+$ ]] || fail "PSNR '$psnr' '$psnr_b'"
[[ $macs =~ ^[1-9][0-9]*$ && $ipr =~ ^[1-9][0-9]*$ && $ipr_b =~ ^[1-9][0-9]*$ ]] ||
  fail "MACs '$macs', instructions per ray '$ipr' '$ipr_b'"
[ "$w" -le 16 ] && [ "$h" -le 16 ] || fail "view size ${w}x$h"
# the before path renders at t_stop 2^-12, the after path at the default: never fewer
# instructions after than before on the same stream and view
[ "$ipr" -le "$ipr_b" ] || fail "after $ipr instructions per ray, before $ipr_b"
table=$(bash "$src/experiments/complexity.sh" "$work/out" --table)
grep -qF "| lego | tiny | $(python3 -c "print(f'{$bytes:,}')") | $psnr |" <<<"$table" || fail "table: $table"
# resumed: the row is kept, nothing is encoded again
bash "$src/experiments/complexity.sh" "$work/out" lego="$data/lego@100" --iters 20 \
  --max-size 16 --threads 1 > "$work/b.out" 2>&1 || fail "second run failed: $(tail -n 20 "$work/b.out")"
[ "$(wc -l < "$csv")" -eq 2 ] || fail "the second run added rows: $(cat "$csv")"
! grep -q "^== lego" "$work/b.out" || fail "the second run encoded again"
echo "scripts_complexity: OK ($bytes bytes, $psnr dB, $ipr / $ipr_b instructions per ray)"
