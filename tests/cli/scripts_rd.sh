#!/usr/bin/env bash
# experiments/rd.sh on the shared Lego at 25x25 for a few iterations: the table's rows and their
# bytes, with and without the uniform-quantization rows, and a second run that keeps the
# finished points instead of training them again.
set -euo pipefail
cnerf=$1 data=$2 work=$3 src=$4
rm -rf "$work" && mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }
export CNERF=$cnerf
run=(--preset tiny --downscale 16 --iters 4 --every 100 --jobs 1)

# --bits "": float32 and one lambda, no quantized copies to take the parameter count from.
bash "$src/experiments/rd.sh" "$data/lego" "$work/a" "${run[@]}" --bits "" --lambdas "1" \
  > "$work/a.out" 2>&1 || fail "rd.sh --bits \"\" failed: $(cat "$work/a.out")"
params=$(sed -n 's/^model: .* \([0-9]*\) parameters$/\1/p' "$work/a/log/float.log")
[ -n "$params" ] || fail "no parameter count in the float log"
grep -q "^float32,,$((4 * params)),[0-9.]*,[0-9.]*$" "$work/a/rd.csv" ||
  fail "float32 row of $params parameters: $(cat "$work/a/rd.csv")"
grep -q "^cnerf,lambda 1,$(stat -c %s "$work/a/lambda-1.cnrf"),[0-9.]*,[0-9.]*$" "$work/a/rd.csv" ||
  fail "lambda row: $(cat "$work/a/rd.csv")"
[ "$(wc -l < "$work/a/rd.csv")" -eq 3 ] || fail "rows: $(cat "$work/a/rd.csv")"

# With a uniform row; the float model and the lambda point are kept (their logs unchanged).
cp "$work/a/log/float.log" "$work/float.log"
bash "$src/experiments/rd.sh" "$data/lego" "$work/a" "${run[@]}" --bits "6" --lambdas "1" \
  > "$work/b.out" 2>&1 || fail "rd.sh --bits 6 failed: $(cat "$work/b.out")"
cmp -s "$work/float.log" "$work/a/log/float.log" || fail "the finished float model was trained again"
grep -q "^float32,,$((4 * params))," "$work/a/rd.csv" || fail "float32 row: $(cat "$work/a/rd.csv")"
grep -q "^uniform,6 bits,$(stat -c %s "$work/a/q6.cnrf"),[0-9.]*,[0-9.]*$" "$work/a/rd.csv" ||
  fail "uniform row: $(cat "$work/a/rd.csv")"
[ "$(wc -l < "$work/a/rd.csv")" -eq 4 ] || fail "rows: $(cat "$work/a/rd.csv")"
echo "rd.sh: $params parameters, rows and resume as expected"

# experiments/rd_goal.sh from that float model (4 iterations): trained on to 6, encoded to a
# size in 3 more (the file the mean of the last 2), a copy trained on to 9; rows, the float
# models' iterations and a second run that keeps every step.
goal=(--at 6 --iters 3 --size 20000 --preset tiny --downscale 16 --threads 1 --every 100
  --average 2)
sum=$(md5sum < "$work/a/float.ckpt")
bash "$src/experiments/rd_goal.sh" "$work/g" "$data/lego" "$work/a/float.ckpt" "${goal[@]}" \
  > "$work/g.out" 2>&1 || fail "rd_goal.sh failed: $(cat "$work/g.out")"
[ "$(md5sum < "$work/a/float.ckpt")" = "$sum" ] || fail "rd_goal.sh changed its float model"
grep -q "^saved .* at iteration 6:" "$work/g/float-6.log" || fail "float-6: $(cat "$work/g/float-6.log")"
grep -q "^saved .* at iteration 9:" "$work/g/float-9.log" || fail "float-9: $(cat "$work/g/float-9.log")"
grep -q "^float32,6,$((4 * params)),[0-9.]*$" "$work/g/goal.csv" || fail "goal.csv: $(cat "$work/g/goal.csv")"
grep -q "^cnerf,9,$(stat -c %s "$work/g/cnerf-20000.cnrf"),[0-9.]*$" "$work/g/goal.csv" ||
  fail "cnerf row: $(cat "$work/g/goal.csv")"
grep -q "^float32,9,$((4 * params)),[0-9.]*$" "$work/g/goal.csv" || fail "goal.csv: $(cat "$work/g/goal.csv")"
grep -q "| cnerf | 9 | " "$work/g/goal.md" || fail "goal.md: $(cat "$work/g/goal.md")"
grep -q "^the file will hold the mean of the parameters over the last 2 iterations$" \
  "$work/g/cnerf-20000.log" || fail "rd_goal.sh --average 2: $(cat "$work/g/cnerf-20000.log")"
cp "$work/g/cnerf-20000.log" "$work/g-cnerf.log"
bash "$src/experiments/rd_goal.sh" "$work/g" "$data/lego" "$work/a/float.ckpt" "${goal[@]}" \
  > "$work/g2.out" 2>&1 || fail "rd_goal.sh again failed: $(cat "$work/g2.out")"
cmp -s "$work/g-cnerf.log" "$work/g/cnerf-20000.log" || fail "the finished encode ran again"
grep -q "training\|encoding" "$work/g2.out" && fail "a finished step ran again: $(cat "$work/g2.out")"
set +e
msg=$(bash "$src/experiments/rd_goal.sh" "$work/g3" "$data/lego" "$work/nope.ckpt" 2>&1); rc=$?
set -e
[ $rc = 1 ] && grep -q "rd_goal.sh: no float checkpoint $work/nope.ckpt" <<<"$msg" ||
  fail "rd_goal.sh without its float checkpoint: $rc $msg"
[ ! -e "$work/g3" ] || fail "rd_goal.sh without its float checkpoint made $work/g3"
echo "rd_goal.sh: three rows, float models at 6 and 9 iterations, resume as expected"
