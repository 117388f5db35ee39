#!/usr/bin/env bash
# scripts/coarse_color.sh on the shared Lego at 25x25 for a few iterations: one row per
# variant with its file's bytes, the stream without the coarse colour the smaller, and a
# second run that keeps the finished variants.
set -euo pipefail
cnerf=$1 data=$2 work=$3 src=$4
rm -rf "$work" && mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }
export CNERF=$cnerf
run=(--lambda 1 --preset tiny --downscale 16 --iters 4 --every 100 --batch 64)
bash "$src/scripts/coarse_color.sh" "$work" t "$data/lego" --weights "0.1 0.5" --threads 2 \
  -- "${run[@]}" > "$work/a.out" 2>&1 || fail "coarse_color.sh failed: $(cat "$work/a.out")"
md=$work/t.md
[ "$(wc -l < "$md")" -eq 6 ] || fail "rows: $(cat "$md")"
row() { grep "^| $1 | $2 | $(stat -c %s "$work/t-$3-$2.cnrf") | [0-9.]* | [0-9.]* |$" "$md" ||
  fail "row $1 $2: $(cat "$md")"; }
row sent 1 on > /dev/null
row "not sent" 1 off > /dev/null
row "not sent" 0.1 off > /dev/null
row "not sent" 0.5 off > /dev/null
[ "$(stat -c %s "$work/t-off-1.cnrf")" -lt "$(stat -c %s "$work/t-on-1.cnrf")" ] ||
  fail "the stream without the coarse colour is not smaller"
grep -q "coarse-color=off; coarse-weight=0.5" <<<"$("$cnerf" info "$work/t-off-0.5.cnrf")" ||
  fail "meta of the 0.5 variant"
# A second run keeps the finished variants (their logs unchanged).
cp "$work/t-on-1.log" "$work/on.log"
bash "$src/scripts/coarse_color.sh" "$work" t "$data/lego" --weights "0.1 0.5" --threads 2 \
  -- "${run[@]}" > "$work/b.out" 2>&1 || fail "second run failed: $(cat "$work/b.out")"
cmp -s "$work/on.log" "$work/t-on-1.log" || fail "a finished variant was encoded again"
! grep -q "coarse_color.sh: t," "$work/b.out" || fail "second run encoded: $(cat "$work/b.out")"
