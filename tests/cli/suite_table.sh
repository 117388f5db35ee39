#!/usr/bin/env bash
# experiments/scene_suite.sh --table on rows made up for it: the bounds it prints per scene
# (the default within 0.3 dB of the better preset (of those the encoder did not refuse), within 3 dB of float tiny; float small
# within 3 dB of float tiny), a file short of its size counted, a missing run said, and the
# worst and slowest scenes named; with --views, the default's lead over the other preset and
# its standard error over the test views; --trajectories and --views on logs made up for them;
# experiments/tiny_warmup.sh --table on eval logs made up for it.
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
refuse,2000,train-tiny,tiny,0,0,20.00,,,1,ok
refuse,2000,train-small,small,0,0,20.50,,,1,ok
refuse,2000,encode-default,tiny,30000,29000,19.50,,,1,ok
refuse,2000,encode-small,small,30000,0,,,,1,refused
CSV
out=$("$src/experiments/scene_suite.sh" "$work" --table)
line() { grep "^| $1 | 2000 | 30000 |" <<<"$out" || fail "no bounds row for $1: $out"; }
[ "$(line good)" = "| good | 2000 | 30000 | -0.25 dB | -0.25 dB | +0.50 dB | +1.00 dB | hold |" ] ||
  fail "good: $(line good)"
[ "$(line close)" = "| close | 2000 | 30000 | -0.40 dB | -0.40 dB | -1.00 dB | -3.50 dB | breaks: preset, float small |" ] ||
  fail "close: $(line close)"
[ "$(line half)" = "| half | 2000 | 30000 | – | – | – | – | not all measured |" ] || fail "half: $(line half)"
# a preset the encoder refused at the size is no candidate: the bound holds against the other
[ "$(line refuse)" = "| refuse | 2000 | 30000 | the other refused | +0.00 dB | -0.50 dB | +0.50 dB | hold |" ] ||
  fail "refuse: $(line refuse)"
grep -qx "worst against the preset bound: close at 2000 iterations, 30000 B (-0.40 dB)" <<<"$out" ||
  fail "the worst scene: $out"
grep -qx "slowest: close at 2000 iterations (1000 s over its runs)" <<<"$out" || fail "the slowest: $out"
# The rows file itself gives the same table as its run folder.
[ "$("$src/experiments/scene_suite.sh" "$work/suite.csv" --table)" = "$out" ] ||
  fail "the table of $work/suite.csv differs from the folder's"
# --trajectories: each encode's course from its log, the iteration lines and the race's.
mkdir -p "$work/log"
cat > "$work/log/close-2000-encode-default-30000.log" <<'LOG'
race 100/2000: validation psnr tiny 15.74 dB, small 15.11 dB (24.76 kB, 69.39 kB), small's lead -0.64 dB over the last 1
preset auto: small, by the race (10 s, 101 iterations of each)
iter 200/2000 loss 0.02 psnr 21.37 dB  size 36.80 kB, plan 37.11, target 30.00, lambda 0.00194  occupied 59%  val 21.25 dB 0.744 s/it ETA 11m10s
iter 300/2000 loss 0.02 psnr 21.40 dB  size 36.00 kB, plan 36.00, target 30.00, lambda 0.002 0.7 s/it ETA 11m00s
LOG
want='scene,iters,run,target,build,iter,size_kb,plan_kb,val_psnr
close,2000,race-tiny,30000,,100,24.76,,15.74
close,2000,race-small,30000,,100,69.39,,15.11
close,2000,encode-default,30000,,200,36.80,37.11,21.25'
got=$("$src/experiments/scene_suite.sh" "$work" --trajectories)
[ "$got" = "$want" ] || fail "--trajectories: $got"
# --views: each view's PSNR from the runs' eval logs; a run without a log has none.
cat > "$work/log/close-2000-encode-default-30000.eval" <<'LOG'
/x/close.cnrf: 30000 bytes
--max-size 100: downscale 8, views 100x100
  r_0              psnr  20.00 dB  ssim 0.9676  0.22 s
  r_1              psnr  18.00 dB  ssim 0.9676  0.22 s
mean over 2 test views (stream): psnr 19.00 dB  ssim 0.9676  0.22 s/view
LOG
cat > "$work/log/close-2000-encode-tiny-30000.eval" <<'LOG'
  r_0              psnr  19.80 dB  ssim 0.9676  0.22 s
  r_1              psnr  19.00 dB  ssim 0.9676  0.22 s
mean over 2 test views (stream): psnr 19.40 dB  ssim 0.9676  0.22 s/view
LOG
want='scene,iters,run,target,view,psnr
close,2000,encode-default,30000,r_0,20.00
close,2000,encode-default,30000,r_1,18.00
close,2000,encode-tiny,30000,r_0,19.80
close,2000,encode-tiny,30000,r_1,19.00'
got=$("$src/experiments/scene_suite.sh" "$work" --views)
[ "$got" = "$want" ] || fail "--views: $got"
# The per-view differences are +0.20 and -1.00 dB: a mean of -0.40 dB and a standard error of
# sqrt(((0.6^2 + 0.6^2) / 1) / 2) = 0.60 dB over 2 views.
"$src/experiments/scene_suite.sh" "$work" --views > "$work/views.csv"
out=$("$src/experiments/scene_suite.sh" "$work/suite.csv" --table --views "$work/views.csv")
[ "$(line close)" = "| close | 2000 | 30000 | -0.40 ± 0.60 dB (2) | -0.40 dB | -1.00 dB | -3.50 dB | breaks: preset, float small |" ] ||
  fail "close with its views: $(line close)"
[ "$(line good)" = "| good | 2000 | 30000 | -0.25 dB | -0.25 dB | +0.50 dB | +1.00 dB | hold |" ] ||
  fail "good without views: $(line good)"
"$src/experiments/scene_suite.sh" "$work/suite.csv" --table --views "$work/none.csv" 2>/dev/null &&
  fail "--table --views with a missing file succeeded"
# experiments/tiny_warmup.sh --table: each scene's two encodes from their eval logs, the
# difference of means with its standard error, a scene with one run said.
tw=$work/tiny_warmup && mkdir -p "$tw"
head -c 25000 /dev/zero > "$tw/alpha-warm20.cnrf"
head -c 24000 /dev/zero > "$tw/alpha-warm0.cnrf"
head -c 23000 /dev/zero > "$tw/beta-warm0.cnrf"
printf '  r_0   psnr  20.00 dB  ssim 0.9\n  r_1   psnr  22.00 dB  ssim 0.9\n' > "$tw/alpha-warm20.cnrf.eval"
printf '  r_0   psnr  20.50 dB  ssim 0.9\n  r_1   psnr  22.10 dB  ssim 0.9\n' > "$tw/alpha-warm0.cnrf.eval"
printf '  r_0   psnr  19.00 dB  ssim 0.9\n' > "$tw/beta-warm0.cnrf.eval"
got=$("$src/experiments/tiny_warmup.sh" --table "$tw" /scenes/alpha /scenes/beta/)
# alpha: differences +0.50 and +0.10, mean +0.30, standard error sqrt(0.08 / 1 / 2) = 0.20
grep -qxF "| alpha | 21.00 dB, 25000 B | 21.30 dB, 24000 B | +0.30 ± 0.20 dB (2) |" <<<"$got" ||
  fail "tiny_warmup alpha: $got"
grep -qxF "| beta | not run | 19.00 dB, 23000 B | – |" <<<"$got" || fail "tiny_warmup beta: $got"
grep -qxF "mean difference over 1 scenes: +0.30 dB; without the warm-up better on 1, worse on 0" <<<"$got" ||
  fail "tiny_warmup summary: $got"
echo "suite_table: ok"
