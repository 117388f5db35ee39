#!/usr/bin/env bash
# cnerf over MPI (-DCNERF_MPI=ON, Open MPI's mpirun): builds that configuration of cnerf, then
#  - train on 1, 2, 3 and 4 ranks writes the checkpoint the build without MPI writes, byte for
#    byte; encode on 1 to 4 ranks (one of them with 2 threads a rank) the same stream and
#    checkpoint;
#  - SIGTERM to a 2-rank run saves the checkpoint; --resume on 3 ranks goes on
#    to the bytes a single process gets from the same checkpoint;
#  - SIGTERM to the ranks themselves saves, says so and exits 143;
#  - a rank killed with SIGKILL ends the job in bounded time with a cnerf line naming it, the
#    checkpoint intact; a rank that hangs ends it after CNERF_MPI_WAIT seconds, named too;
#  - a joint encode of two scenes on 2 ranks writes one process's stream;
#  - eval on 3 ranks reports and writes what one process does; --eval-every and encode's
#    test views, split among the ranks, score as in one process;
#  - a command other than train, encode and eval refuses to run on several ranks.
set -euo pipefail
cnerf=$1 src=$2 data=$3 work=$4
rm -rf "$work/runs" && mkdir -p "$work/runs"
# (Lego and Mic with 10 training and 10 validation views: every rank reads them all)
data=$(bash "$(dirname "$0")/few_views.sh" "$data" "$work/data")
fail() { echo "FAIL: $*" >&2; exit 1; }
command -v mpirun > /dev/null || fail "no mpirun (Debian: apt-get install openmpi-bin libopenmpi-dev)"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=passive
export OMPI_MCA_btl_vader_single_copy_mechanism=none # containers without CMA
mpirun=(mpirun --oversubscribe --bind-to none)

cmake -S "$src" -B "$work/build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCNERF_MPI=ON > "$work/configure.log" 2>&1 ||
  fail "configure with -DCNERF_MPI=ON: $(tail -5 "$work/configure.log")"
cmake --build "$work/build" -j2 --target cnerf > "$work/build.log" 2>&1 ||
  fail "build with -DCNERF_MPI=ON: $(tail -5 "$work/build.log")"
mcnerf=$work/build/cnerf
cd "$work/runs"

# (600 rays a batch: 5 chunks of CN_CHUNK_RAYS, which 2, 3 and 4 ranks split unevenly)
train=(train "$data/lego" --preset tiny --downscale 8 --seed 1 --every 100 --batch 600)
# (--eval-every: the 2 test views are split among the ranks, 4 ranks leave 2 with none)
"$cnerf" "${train[@]}" -o one.ckpt --iters 12 --eval-every 6 --threads 2 > one.log 2>&1 ||
  fail "train: $(tail -3 one.log)"
for n in 1 2 3 4; do
  "${mpirun[@]}" -np $n "$mcnerf" "${train[@]}" -o r$n.ckpt --iters 12 --eval-every 6 --threads 1 \
    > r$n.log 2>&1 || fail "mpirun -np $n train: $(tail -5 r$n.log)"
  cmp -s one.ckpt r$n.ckpt || fail "train on $n ranks: the checkpoint differs from one process's"
  [ ! -e r$n.ckpt.lock ] || fail "train on $n ranks left its lock"
  [ "$(grep "^eval:" one.log | sed 's/training [0-9.]* s, //')" = \
    "$(grep "^eval:" r$n.log | sed 's/training [0-9.]* s, //')" ] ||
    fail "train on $n ranks: the evaluations differ: $(grep "^eval:" r$n.log)"
done
grep -q "^saved r4.ckpt at iteration 12" r4.log || fail "train on 4 ranks: no summary: $(tail -3 r4.log)"
[ "$(grep -c "^saved r4.ckpt" r4.log)" = 1 ] || fail "train on 4 ranks: more than rank 0 printed"
echo "train: 1 process and 1 to 4 ranks: $(md5sum < one.ckpt | cut -c1-32)"

# (a run this short misses its --size: that exits 1 with the file written)
# (--grid 0 here and in the joint encode: the occupancy grid's measurement, 3.5 s of a 6 s
# encode, runs whole on every rank with no MPI in it; cli_train runs it)
enc=(encode "$data/lego" --preset tiny --downscale 8 --batch 600 --iters 10 --size 30000 --every 100 --seed 3
     --grid 0)
"$cnerf" "${enc[@]}" -o one.cnrf --threads 2 > enc-one.log 2>&1 || grep -q "(the file is written)" enc-one.log ||
  fail "encode: $(tail -3 enc-one.log)"
# (1 to 4 ranks, the 2 ranks with 2 threads each: the threads per rank may vary too)
for n in 1 2 3 4; do
  threads=1; [ $n = 2 ] && threads=2
  "${mpirun[@]}" -np $n "$mcnerf" "${enc[@]}" -o e$n.cnrf --threads $threads > enc$n.log 2>&1 ||
    grep -q "(the file is written)" enc$n.log || fail "mpirun -np $n encode: $(tail -5 enc$n.log)"
  cmp -s one.cnrf e$n.cnrf || fail "encode on $n ranks: the stream differs from one process's"
  cmp -s one.cnrf.ckpt e$n.cnrf.ckpt || fail "encode on $n ranks: the checkpoint differs"
  [ "$(grep "^test:" enc-one.log)" = "$(grep "^test:" enc$n.log)" ] ||
    fail "encode on $n ranks: the test views score otherwise: $(grep "^test:" enc$n.log)"
done
echo "encode: 1 process, 1 to 4 ranks: $(md5sum < one.cnrf | cut -c1-32)"

# Two scenes in one stream (shared shifts) on 2 ranks: one process's stream and report.
joint=(encode "$data/lego" "$data/mic" --preset tiny --downscale 8 --batch 600 --iters 20 --lambda 1 --every 100 --seed 3
       --grid 0)
"$cnerf" "${joint[@]}" -o j1.cnrf --threads 2 > j1.log 2>&1 || fail "joint encode: $(tail -3 j1.log)"
"${mpirun[@]}" -np 2 "$mcnerf" "${joint[@]}" -o j2.cnrf --threads 1 > j2.log 2>&1 ||
  fail "mpirun -np 2 joint encode: $(tail -5 j2.log)"
cmp -s j1.cnrf j2.cnrf || fail "joint encode on 2 ranks: the stream differs from one process's"
cmp -s j1.cnrf.ckpt j2.cnrf.ckpt || fail "joint encode on 2 ranks: the checkpoint differs"
[ "$(grep "test:" j1.log)" = "$(grep "test:" j2.log)" ] ||
  fail "joint encode on 2 ranks: the test views score otherwise: $(grep "test:" j2.log)"
echo "joint encode of 2 scenes: 1 process and 2 ranks: $(md5sum < j1.cnrf | cut -c1-32)"

# SIGTERM to mpirun: Open MPI 4.1's sends the ranks SIGCONT, waits odls_base_sigkill_timeout,
# sends SIGTERM, waits again, then SIGKILL; the ranks stop after the same step and rank 0 saves
# within the second wait. mpirun holds the ranks' output during its waits and may drop the
# last lines of a job it ends (rank 0's "interrupted by SIGTERM: saved ..." among them, seen
# once), so the checkpoint itself is what is checked: a run of 100,000 iterations with no
# periodic checkpoint writes one only at the stop.
"${mpirun[@]}" --mca odls_base_sigkill_timeout 10 -np 2 "$mcnerf" "${train[@]}" -o term.ckpt --iters 100000 --ckpt-secs 1000000 --threads 1 --log-every 2 \
  > term.log 2>&1 &
pid=$!
for _ in $(seq 600); do grep -q "iter 6/" term.log 2>/dev/null && break; sleep 0.5; done
kill -TERM $pid
wait $pid && fail "a SIGTERM'd run exited 0"
[ -s term.ckpt ] || fail "SIGTERM: no checkpoint saved: $(tail -5 term.log)"
[ ! -e term.ckpt.lock ] || fail "SIGTERM: the lock is left"
if grep -q "interrupted by SIGTERM: saved term.ckpt" term.log; then said="said so"; else said="its line dropped by mpirun"; fi
cp term.ckpt probe.ckpt
"$cnerf" "${train[@]}" -o probe.ckpt --resume --iters 1 --threads 1 > probe.log 2>&1 ||
  fail "the SIGTERM checkpoint does not load: $(tail -3 probe.log)"
it=$(sed -n 's/^probe.ckpt is at iteration \([0-9]*\) of 1.*/\1/p' probe.log)
[ -n "$it" ] && [ "$it" -ge 6 ] || fail "the SIGTERM checkpoint: $(tail -3 probe.log)"
# --resume on another number of ranks: the bytes one process gets from the same checkpoint.
cp term.ckpt term1.ckpt
"$cnerf" "${train[@]}" -o term1.ckpt --resume --iters $((it + 4)) --threads 2 > res1.log 2>&1 ||
  fail "resume: $(tail -3 res1.log)"
"${mpirun[@]}" -np 3 "$mcnerf" "${train[@]}" -o term.ckpt --resume --iters $((it + 4)) --threads 1 \
  > res3.log 2>&1 || fail "mpirun -np 3 --resume: $(tail -5 res3.log)"
cmp -s term1.ckpt term.ckpt || fail "a 2-rank checkpoint resumed on 3 ranks differs from one process's"
echo "SIGTERM: saved at iteration $it ($said), resumed on 3 ranks: as one process"

# The rank of a process of the job: Open MPI puts it in the environment.
rank_pid() { # JOB_PID RANK
  for p in $(pgrep -P "$1"); do
    tr '\0' '\n' < /proc/$p/environ 2>/dev/null | grep -qx "OMPI_COMM_WORLD_RANK=$2" && { echo $p; return; }
  done
}

# SIGTERM to the ranks themselves (as Slurm's scancel sends it): they stop after the same step,
# rank 0 saves and says so, and the job exits 143.
"${mpirun[@]}" -np 2 "$mcnerf" "${train[@]}" -o direct.ckpt --iters 100000 --threads 1 --log-every 2 \
  > direct.log 2>&1 &
pid=$!
for _ in $(seq 600); do grep -q "iter 6/" direct.log 2>/dev/null && break; sleep 0.5; done
kill -TERM $(pgrep -P $pid)
rc=0; wait $pid || rc=$?
[ $rc = 143 ] || fail "SIGTERM to the ranks: the job exited $rc, not 143: $(tail -5 direct.log)"
grep -q "^interrupted by SIGTERM: saved direct.ckpt at iteration" direct.log ||
  fail "SIGTERM to the ranks: no checkpoint saved: $(tail -5 direct.log)"
echo "SIGTERM to the ranks: $(grep "^interrupted" direct.log | cut -d: -f1-2), exit 143"

# Each rank's stderr straight to a file of its own (rank_err.N), past mpirun, which may drop
# what a rank writes while it ends the job (see the SIGTERM case above).
own_stderr=(sh -c 'exec "$0" "$@" 2>> "rank_err.$OMPI_COMM_WORLD_RANK"')

# A rank killed: the job ends (Open MPI's mpirun ends the others), a cnerf line names the rank,
# and the last checkpoint is whole. Rank 0 names rank 1; rank 1 names rank 0.
# (mpirun sends the others SIGTERM one odls_base_sigkill_timeout after the death and SIGKILL
# one later; the line comes 0.5 s after the SIGTERM, so the timeout is 3 s here, not the 1 s
# default, for a loaded machine.)
for victim_rank in 1 0; do
  rm -f rank_err.*
  "${mpirun[@]}" --mca odls_base_sigkill_timeout 3 -np 2 "${own_stderr[@]}" "$mcnerf" "${train[@]}" -o dead.ckpt --iters 100000 --threads 1 --log-every 2 \
    --ckpt-every 4 > dead.log 2>&1 &
  pid=$!
  for _ in $(seq 600); do grep -q "iter 10/" dead.log 2>/dev/null && break; sleep 0.5; done
  victim=$(rank_pid $pid $victim_rank)
  [ -n "$victim" ] || fail "no rank $victim_rank to kill"
  kill -KILL "$victim"
  t0=$(date +%s)
  for _ in $(seq 120); do kill -0 $pid 2>/dev/null || break; sleep 0.5; done
  kill -0 $pid 2>/dev/null && { kill -KILL $pid; fail "a killed rank: the job still runs after 60 s"; }
  wait $pid && fail "a job with a killed rank exited 0"
  cat rank_err.* > dead.err 2>/dev/null || true
  grep -q "^cnerf train: rank [01] has waited .* rank $victim_rank of 2 has not answered the stop signal (it has died or hangs)" dead.err ||
    fail "rank $victim_rank killed: no cnerf line names it: $(cat dead.err; tail -n 5 dead.log)"
  "$cnerf" "${train[@]}" -o dead.ckpt --resume --iters 13 --threads 2 > dead-res.log 2>&1 ||
    fail "the checkpoint of a job with a killed rank does not resume: $(tail -3 dead-res.log)"
  echo "rank $victim_rank killed: the job ended after $(( $(date +%s) - t0 )) s; $(grep "^cnerf train" dead.err | cut -d: -f2- | cut -c1-60)...; $(grep resumed dead-res.log)"
  rm -f dead.ckpt
done

# A rank that hangs (stopped): the job ends after CNERF_MPI_WAIT seconds, a cnerf line names it.
rm -f rank_err.*
"${mpirun[@]}" -x CNERF_MPI_WAIT=5 -np 2 "${own_stderr[@]}" "$mcnerf" "${train[@]}" -o hang.ckpt --iters 100000 --threads 1 \
  --log-every 2 > hang.log 2>&1 &
pid=$!
for _ in $(seq 600); do grep -q "iter 10/" hang.log 2>/dev/null && break; sleep 0.5; done
victim=$(rank_pid $pid 1)
[ -n "$victim" ] || fail "no rank 1 to stop"
kill -STOP "$victim"
t0=$(date +%s)
for _ in $(seq 120); do kill -0 $pid 2>/dev/null || break; sleep 0.5; done
kill -0 $pid 2>/dev/null && { kill -CONT "$victim"; kill -KILL $pid; fail "a hung rank: the job still runs after 60 s"; }
wait $pid && fail "a job with a hung rank exited 0"
cat rank_err.* > hang.err 2>/dev/null || true
grep -q "^cnerf train: rank 0 has waited [5-9].* rank 1 of 2 has not answered a ping in 1 s (it has died or hangs); ending every rank" hang.err ||
  fail "a hung rank: no cnerf line names it: $(cat hang.err; tail -n 5 hang.log)"
echo "rank 1 hung: the job ended after $(( $(date +%s) - t0 )) s; $(grep "^cnerf train" hang.err | head -n 1 | cut -d: -f2- | cut -c1-90)..."

# eval on 3 ranks: each renders a third of the views and writes them; the report and the
# files are one process's.
strip() { sed 's/ [0-9.]* s$//; s/ [0-9.]* s\/view$//' "$1"; }
"$cnerf" eval one.cnrf "$data/lego" --downscale 8 --every 25 -o ev1 --threads 2 > ev1.log 2>&1 ||
  fail "eval: $(tail -3 ev1.log)"
"${mpirun[@]}" -np 3 "$mcnerf" eval one.cnrf "$data/lego" --downscale 8 --every 25 -o ev3 --threads 1 \
  > ev3.log 2>&1 || fail "mpirun -np 3 eval: $(tail -5 ev3.log)"
[ "$(strip ev1.log)" = "$(strip ev3.log)" ] || fail "eval on 3 ranks reports otherwise: $(diff <(strip ev1.log) <(strip ev3.log))"
[ "$(cd ev1 && md5sum ./*.png)" = "$(cd ev3 && md5sum ./*.png)" ] || fail "eval on 3 ranks wrote other views"
echo "eval: 1 process and 3 ranks: $(strip ev3.log | tail -n 1), $(ls ev3 | wc -l) views"

# Commands that run as one process refuse several ranks.
if "${mpirun[@]}" -np 2 "$mcnerf" info one.cnrf > info.log 2>&1; then fail "info ran on 2 ranks"; fi
grep -q "cnerf info: runs as one process" info.log || fail "info on 2 ranks: $(cat info.log)"
# A wait limit that is not a number of seconds is refused before any work.
if "${mpirun[@]}" -x CNERF_MPI_WAIT=soon -np 2 "$mcnerf" "${train[@]}" -o never.ckpt --iters 2 \
  > wait.log 2>&1; then fail "CNERF_MPI_WAIT=soon was taken"; fi
grep -q "cnerf: CNERF_MPI_WAIT=soon: give seconds, more than 0" wait.log ||
  fail "CNERF_MPI_WAIT=soon: $(cat wait.log)"
[ ! -e never.ckpt ] || fail "CNERF_MPI_WAIT=soon: a checkpoint was written"
echo "OK"
