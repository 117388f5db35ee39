#!/usr/bin/env bash
# experiments/scene_suite.sh --table on rows made up for it: the bounds it prints per scene
# (the default within 0.3 dB of the better preset, within 3 dB of float tiny; float small
# within 3 dB of float tiny), a file short of its size counted, a missing run said, and the
# worst and slowest scenes named.
set -euo pipefail
src=$1 work=$2
rm -rf "$work" && mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }
cat > "$work/suite.csv" <<'CSV'
scene,iters,run,preset,target,bytes,test_psnr,val_psnr,fit_psnr,seconds,status
good,2000,train-tiny,tiny,0,0,20.00,,,10,ok
good,2000,train-small,small,0,0,21.00,,,20,ok
good,2000,encode-default,tiny,30000,25000,20.50,,,30,missed-size
good,2000,encode-small,small,30000,30000,20.75,,,40,ok
close,2000,train-tiny,tiny,0,0,20.00,,,100,ok
close,2000,train-small,small,0,0,16.50,,,200,ok
close,2000,encode-default,small,30000,30000,19.00,,,300,ok
close,2000,encode-tiny,tiny,30000,24000,19.40,,,400,missed-size
half,2000,train-tiny,tiny,0,0,20.00,,,1,ok
CSV
out=$("$src/experiments/scene_suite.sh" "$work" --table)
line() { grep "^| $1 | 2000 | 30000 |" <<<"$out" || fail "no bounds row for $1: $out"; }
[ "$(line good)" = "| good | 2000 | 30000 | -0.25 dB | +0.50 dB | +1.00 dB | hold |" ] ||
  fail "good: $(line good)"
[ "$(line close)" = "| close | 2000 | 30000 | -0.40 dB | -1.00 dB | -3.50 dB | breaks: preset, float small |" ] ||
  fail "close: $(line close)"
[ "$(line half)" = "| half | 2000 | 30000 | – | – | – | not all measured |" ] || fail "half: $(line half)"
grep -qx "worst against the preset bound: close at 2000 iterations, 30000 B (-0.40 dB)" <<<"$out" ||
  fail "the worst scene: $out"
grep -qx "slowest: close at 2000 iterations (1000 s over its runs)" <<<"$out" || fail "the slowest: $out"
# The rows file itself gives the same table as its run folder.
[ "$("$src/experiments/scene_suite.sh" "$work/suite.csv" --table)" = "$out" ] ||
  fail "the table of $work/suite.csv differs from the folder's"
echo "suite_table: ok"
