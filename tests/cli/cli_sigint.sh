#!/usr/bin/env bash
# Ctrl-C pressed over and over during training (tests/tools/sigstorm: a SIGINT every 200 us
# from the first progress line on), and SIGTERM and SIGHUP the same way: cnerf train and
# encode must save a checkpoint that loads, say so and exit with status 128 + the signal,
# however many signals land inside the matrix products or during the save. oneDNN's x64 GEMM
# kernels point the stack pointer into the heap while they run, so a signal handler that
# runs on one of their threads corrupts the heap (an abort in the next malloc or free).
set -euo pipefail
cnerf=$1 data=$2 work=$3 sigstorm=$4
rm -rf "$work" && mkdir -p "$work"
# (Lego and Mic with 10 training and 10 validation views: each run reads fewer images)
data=$(bash "$(dirname "$0")/few_views.sh" "$data" "$work/data")
fail() { echo "FAIL: $*" >&2; exit 1; }
common=(--preset small --downscale 8 --batch 2048 --iters 100000 --log-every 1 --threads 2)

# Rounds: Ctrl-C, then what schedulers (SIGTERM) and a closed terminal (SIGHUP) send.
round=0
for sig in INT TERM HUP; do
  round=$((round + 1))
  want=$((128 + $(kill -l "$sig")))
  for cmd in train encode; do
    out="$work/$cmd$round"
    extra=()
    [ $cmd = encode ] && extra=(--lambda 1)
    set +e
    "$sigstorm" -s "$sig" "iter " 200 30000 -- "$cnerf" $cmd "$data/lego" -o "$out.x" \
      "${common[@]}" "${extra[@]}" > "$out.log" 2> "$out.err"
    rc=$?
    set -e
    [ $rc -eq $want ] || fail "$cmd SIG$sig exited $rc, want $want: $(tail -5 "$out.err")"
    ckpt="$out.x"
    [ $cmd = encode ] && ckpt="$out.x.ckpt"
    grep -q "^interrupted by SIG$sig: saved $ckpt at iteration [1-9]" "$out.log" ||
      fail "$cmd SIG$sig: no save: $(tail -3 "$out.log")"
    "$cnerf" eval "$ckpt" "$data/lego" --downscale 8 --every 200 > "$out.eval" ||
      fail "$cmd SIG$sig: the checkpoint does not load"
    echo "$cmd SIG$sig: $(grep -o 'saved .* at iteration [0-9]*' "$out.log"), $(cat "$out.err")"
  done
done

# kill -9, which no program can catch: the log written to a file has every line printed
# before it (stdout is line-buffered when it is not a terminal), and the checkpoint that
# --ckpt-secs wrote resumes.
out="$work/kill9"
"$cnerf" train "$data/lego" -o "$out.ckpt" "${common[@]}" --log-every 1000000 --ckpt-secs 1 \
  > "$out.log" 2> "$out.err" &
pid=$!
for _ in $(seq 600); do
  [ -s "$out.ckpt" ] && break
  kill -0 $pid 2> /dev/null || fail "kill -9: train exited early: $(tail -3 "$out.err")"
  sleep 0.2
done
[ -s "$out.ckpt" ] || fail "kill -9: no checkpoint after 120 s"
kill -9 $pid
wait $pid 2> /dev/null || true
grep -q "^model: " "$out.log" || fail "kill -9: the log lost its lines: '$(cat "$out.log")'"
"$cnerf" train "$data/lego" -o "$out.ckpt" "${common[@]}" --iters 1 --resume > "$out.resume" ||
  fail "kill -9: resume failed"
grep -q "^resumed $out.ckpt at iteration [1-9]" "$out.resume" ||
  fail "kill -9: $(cat "$out.resume")"
echo "kill -9: $(grep -o 'at iteration [0-9]*' "$out.resume" | head -1) resumed, log kept"

# nohup's contract: a stop signal the caller ignores (SIG_IGN, inherited across exec) stays
# ignored. SIGHUP then does not stop the run, and SIGTERM still does.
out="$work/nohup"
( trap '' HUP; exec "$cnerf" train "$data/lego" -o "$out.ckpt" "${common[@]}" > "$out.log" \
  2> "$out.err" ) &
pid=$!
for _ in $(seq 600); do
  grep -q "^iter " "$out.log" && break
  kill -0 $pid 2> /dev/null || fail "nohup: train exited early: $(tail -3 "$out.err")"
  sleep 0.2
done
kill -HUP $pid
sleep 2
kill -0 $pid 2> /dev/null || fail "nohup: SIGHUP stopped a run that ignores it: $(tail -2 "$out.log")"
kill -TERM $pid
set +e
wait $pid
rc=$?
set -e
[ $rc -eq 143 ] || fail "nohup: SIGTERM exited $rc, want 143"
echo "nohup: SIGHUP ignored, SIGTERM stopped the run"

# Outside the training loop too, a stop signal says in one line what was saved, what was not
# and how to go on, and leaves no lock or temporary file behind. CNERF_TEST_TERM_AT=PHASE
# makes the process send itself SIGTERM as it enters that phase and wait there.
# stop_in CMD PHASE OUT ARGS...: runs cnerf CMD ARGS -o OUT.x, SIGTERM in PHASE.
stop_in() {
  local cmd=$1 phase=$2 o=$3
  shift 3
  set +e
  CNERF_TEST_TERM_AT=$phase "$cnerf" "$cmd" "$@" -o "$o.x" > "$o.log" 2> "$o.err"
  rc=$?
  set -e
  [ $rc -eq 143 ] || fail "$cmd: SIGTERM in the phase $phase exited $rc, want 143: $(tail -3 "$o.err")"
  ! ls "$work" | grep -q "^$(basename "$o").x.*\(lock\|tmp\)" ||
    fail "$cmd: SIGTERM in the phase $phase left $(ls "$work" | grep "^$(basename "$o").x.*\(lock\|tmp\)")"
  echo "$cmd SIGTERM in the phase $phase: $(grep '^interrupted' "$o.log")"
}
short=(--preset tiny --downscale 16 --iters 3 --threads 2)
for cmd in train encode; do
  extra=()
  [ $cmd = encode ] && extra=(--lambda 1 --every 20)
  for phase in load start; do
    o="$work/$phase-$cmd"
    stop_in $cmd $phase "$o" "$data/lego" "${short[@]}" "${extra[@]}"
    want="while loading the dataset"
    [ $phase = start ] && want="before training"
    grep -q "^interrupted by SIGTERM $want: nothing saved; run the command again$" "$o.log" ||
      fail "$cmd: SIGTERM in the phase $phase said: '$(cat "$o.log")'"
    [ ! -e "$o.x" ] && [ ! -e "$o.x.ckpt" ] || fail "$cmd: SIGTERM in the phase $phase wrote a file"
  done
done
# --preset auto's race of tiny and small saves nothing (docs/cli.md): a stop in it says so.
o="$work/race-encode"
stop_in encode race "$o" "$data/lego" --size 40000 --iters 1000 --every 100 --downscale 16 \
  --threads 2
grep -q "^interrupted by SIGTERM while --preset auto races tiny and small: nothing saved; run the command again$" \
  "$o.log" || fail "encode: SIGTERM in the race said: '$(cat "$o.log")'"
[ ! -e "$o.x" ] && [ ! -e "$o.x.ckpt" ] || fail "encode: SIGTERM in the race wrote a file"
o="$work/after-train"
stop_in train after-training "$o" "$data/lego" "${short[@]}"
grep -q "^interrupted by SIGTERM after training: saved $o.x at iteration 3; the model is complete, its validation not measured (cnerf eval $o.x $data/lego measures it)$" \
  "$o.log" || fail "train: SIGTERM after training said: '$(tail -2 "$o.log")'"
"$cnerf" eval "$o.x" "$data/lego" --downscale 16 --every 200 > /dev/null ||
  fail "train: the checkpoint saved before SIGTERM after training does not load"
o="$work/after-encode"
stop_in encode after-training "$o" "$data/lego" "${short[@]}" --lambda 1 --every 20
grep -q "^interrupted by SIGTERM after training: saved $o.x.ckpt at iteration 3; $o.x not written: run the command again with --resume $o.x.ckpt to write it$" \
  "$o.log" || fail "encode: SIGTERM after training said: '$(tail -2 "$o.log")'"
[ ! -e "$o.x" ] || fail "encode: SIGTERM after training wrote the stream"
"$cnerf" encode "$data/lego" -o "$o.x" "${short[@]}" --lambda 1 --every 20 --resume "$o.x.ckpt" \
  > "$o.resume" || fail "encode: the advice after SIGTERM after training failed: $(tail -2 "$o.resume")"
[ -s "$o.x" ] || fail "encode: the advice after SIGTERM after training wrote no stream"
o="$work/wrote-encode"
stop_in encode wrote "$o" "$data/lego" "${short[@]}" --lambda 1 --every 20
grep -q "^interrupted by SIGTERM after training: saved $o.x.ckpt at iteration 3 and wrote $o.x; its measurement was not finished" \
  "$o.log" || fail "encode: SIGTERM after the stream said: '$(tail -2 "$o.log")'"
"$cnerf" info --no-estimate "$o.x" > /dev/null || fail "encode: the stream written before SIGTERM does not load"
# A temporary file of a run killed in the middle of a write (kill -9: nothing removes it) is
# removed by the next run to that output, while it holds the lock; one of a live process is
# kept.
o="$work/stale"
sleep 1000 & live=$!
: > "$o.x.tmp.$live"
( exit 0 ) & dead=$!; wait $dead
: > "$o.x.tmp.$dead"
"$cnerf" train "$data/lego" -o "$o.x" "${short[@]}" > "$o.log" || fail "stale: train failed"
[ ! -e "$o.x.tmp.$dead" ] || fail "stale: the temporary file of the gone process $dead was kept"
[ -e "$o.x.tmp.$live" ] || fail "stale: the temporary file of the live process $live was removed"
kill $live
echo "stale temporaries: that of a gone process removed, that of a live one kept"
