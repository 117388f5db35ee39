#!/usr/bin/env bash
# experiments/encode_variants.sh on the shared Lego at 25x25 for a few iterations: one row per
# variant with its file's bytes, a variant's option replacing the common one, a file that
# misses its --size kept with a warning, and a second run that keeps the finished variants.
set -euo pipefail
cnerf=$1 data=$2 work=$3 src=$4
rm -rf "$work" && mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }
export CNERF=$cnerf
run=(--preset tiny --downscale 16 --iters 4 --every 100 --batch 64)
go() {
  bash "$src/experiments/encode_variants.sh" "$work" "$data/lego" --threads 2 \
    --variant "base --lambda 1" --variant "pc0 --lambda 1 --precrop-iters 0" \
    --variant "l30 --lambda 1 --lambda 30" --variant "big --size 150000" -- "${run[@]}"
}
go > "$work/a.out" 2>&1 || fail "encode_variants.sh failed: $(cat "$work/a.out")"
md=$work/variants.md
[ "$(wc -l < "$md")" -eq 6 ] || fail "rows: $(cat "$md")"
grep -q "big: encode exited non-zero, the row is kept" "$work/a.out" ||
  fail "no warning for the file under its size: $(cat "$work/a.out")"
for v in "base | --lambda 1" "pc0 | --lambda 1 --precrop-iters 0" "l30 | --lambda 1 --lambda 30" \
  "big | --size 150000"; do
  name=${v%% *}
  grep -q "^| $v | $(stat -c %s "$work/$name.cnrf") | [0-9.]* | -\?[0-9.]* |$" "$md" ||
    fail "row $name: $(cat "$md")"
done
cmp -s "$work/base.cnrf" "$work/pc0.cnrf" && fail "the variant's option changed nothing"
[ "$(stat -c %s "$work/l30.cnrf")" -lt "$(stat -c %s "$work/base.cnrf")" ] ||
  fail "--lambda 30 given again did not replace --lambda 1"
# A second run keeps the finished variants (their logs unchanged).
cp "$work/base.log" "$work/keep.log"
go > "$work/b.out" 2>&1 || fail "second run failed: $(cat "$work/b.out")"
cmp -s "$work/keep.log" "$work/base.log" || fail "a finished variant was encoded again"
! grep -q "^encode_variants.sh: " "$work/b.out" || fail "second run encoded: $(cat "$work/b.out")"
