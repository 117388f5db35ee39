#!/usr/bin/env bash
# experiments/round_steps.sh on a float model of the shared Lego at 25x25 trained for a few
# iterations: a row per scheme and step with bytes and PSNR; bytes fall as the step grows;
# a tiny step leaves the picture as the float model renders it, a huge one does not; the
# per-row rows pay two bytes a row; a compressed checkpoint is refused; a second run keeps
# the finished rows.
set -euo pipefail
cnerf=$1 data=$2 work=$3 src=$4 tool=$5
rm -rf "$work" && mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }
export CNERF=$cnerf ROUND_STEPS=$tool
"$cnerf" train "$data/lego" -o "$work/f.ckpt" --preset tiny --downscale 16 --iters 150 \
  --batch 256 --threads 2 > "$work/train.out" 2>&1 || fail "train: $(cat "$work/train.out")"
ev=(--downscale 16 --every 100 --threads 2)
go() { bash "$src/experiments/round_steps.sh" "$work/r" "$work/f.ckpt" "$data/lego" "0.0001 0.3 10" -- "${ev[@]}"; }
go > "$work/a.out" 2>&1 || fail "round_steps.sh failed: $(cat "$work/a.out")"
csv=$work/r/round_steps.csv
[ "$(wc -l < "$csv")" -eq 8 ] || fail "rows: $(cat "$csv")"
[ "$(wc -l < "$work/r/round_steps.md")" -eq 9 ] || fail "table: $(cat "$work/r/round_steps.md")"
col() { awk -F, -v s="$1" -v c="$2" -v k="$3" '$1 == s && $2 == c { print $k }' "$csv"; }
fp=$(col float "" 6)
for s in layer row; do
  b1=$(col $s 0.0001 5) b2=$(col $s 0.3 5) b3=$(col $s 10 5)
  [ "$b1" -gt "$b2" ] && [ "$b2" -gt "$b3" ] || fail "$s: bytes do not fall with the step: $b1 $b2 $b3"
  awk -v a="$(col $s 0.0001 6)" -v f="$fp" 'BEGIN { exit !(a - f < 0.02 && f - a < 0.02) }' ||
    fail "$s: a step of 1e-4 RMS changed the PSNR: $(col $s 0.0001 6) against $fp"
  awk -v a="$(col $s 10 6)" -v f="$fp" 'BEGIN { exit !(f - a > 1) }' ||
    fail "$s: a step of 10 RMS cost under 1 dB: $(col $s 10 6) against $fp"
done
[ "$(col layer 0.3 4)" -eq 0 ] && [ "$(col row 0.3 4)" -gt 0 ] || fail "step bytes: $(cat "$csv")"
[ "$(col row 0.3 5)" -eq $(($(col row 0.3 3) + $(col row 0.3 4))) ] || fail "row total: $(cat "$csv")"
# A compressed checkpoint is refused.
"$cnerf" encode "$data/lego" -o "$work/c.cnrf" --lambda 1 --preset tiny --downscale 16 --iters 2 \
  --batch 64 --every 100 --threads 2 > "$work/enc.out" 2>&1 || fail "encode: $(cat "$work/enc.out")"
if "$tool" "$work/c.cnrf.ckpt" "$work/x.ckpt" layer 0.1 > "$work/c.out" 2>&1; then
  fail "a compressed checkpoint was rounded"
fi
grep -q "is a compressed checkpoint" "$work/c.out" || fail "message: $(cat "$work/c.out")"
# A second run keeps the finished rows.
cp "$work/r/row-0.3.log" "$work/keep.log"
go > "$work/b.out" 2>&1 || fail "second run failed: $(cat "$work/b.out")"
cmp -s "$work/keep.log" "$work/r/row-0.3.log" || fail "a finished row was run again"
! grep -q "^round_steps.sh: " "$work/b.out" || fail "second run ran: $(cat "$work/b.out")"
echo "round_steps.sh: $(tail -n +2 "$csv" | tr '\n' ' ')"
