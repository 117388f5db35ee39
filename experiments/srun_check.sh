#!/usr/bin/env bash
# cnerf launched by Slurm's srun on this one machine: starts a one-node Slurm (munged,
# slurmctld, slurmd; its configuration, state and logs under OUT) and checks that
#  - `srun -n N --mpi=pmix cnerf train` (N = 2, 3) writes the checkpoint one process writes,
#    byte for byte, and prints one log;
#  - `scancel --signal=TERM` and a plain `scancel` stop the ranks after the same step, rank 0
#    saves, and the step exits 143; the checkpoint resumes on 2 ranks to one process's bytes;
#  - what Slurm does when a rank is killed (printed, not checked: Slurm ends the step).
# Needs root and Debian's slurm-wlm and munge (apt-get install slurm-wlm munge), and cnerf
# built with -DCNERF_MPI=ON. The daemons are stopped at the end. docs/training.md, "Several
# processes (MPI)".
#   experiments/srun_check.sh BUILD-MPI/cnerf DATA OUT
set -euo pipefail
[ $# = 3 ] || { echo "usage: $0 BUILD-MPI/cnerf DATA OUT" >&2; exit 2; }
mcnerf=$(realpath "$1") data=$(realpath "$2") out=$3
for c in munged munge unmunge slurmctld slurmd srun scancel sinfo squeue; do
  command -v $c > /dev/null || { echo "$0: no $c (apt-get install slurm-wlm munge)" >&2; exit 2; }
done
[ "$(id -u)" = 0 ] || { echo "$0: run as root (it starts slurmd)" >&2; exit 2; }
mkdir -p "$out" && out=$(realpath "$out")
rm -rf "$out/state" "$out/spool" "$out/runs" && mkdir -p "$out/state" "$out/spool" "$out/runs"
export OMP_WAIT_POLICY=passive OMPI_MCA_btl_vader_single_copy_mechanism=none
fail() { echo "FAIL: $*" >&2; exit 1; }

# munge: the key the package made; munged as its user, unless one answers already.
if ! munge -n 2> /dev/null | unmunge > /dev/null 2>&1; then
  mkdir -p /run/munge /var/log/munge /var/lib/munge
  chown munge:munge /run/munge /var/log/munge /var/lib/munge
  su -s /bin/sh munge -c /usr/sbin/munged
  started_munge=1
fi
munge -n | unmunge > /dev/null || fail "munge does not answer"

host=$(hostname -s)
cat > "$out/slurm.conf" <<EOF
ClusterName=cnerfcheck
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
StateSaveLocation=$out/state
SlurmdSpoolDir=$out/spool
SlurmctldPidFile=$out/slurmctld.pid
SlurmdPidFile=$out/slurmd.pid
SlurmctldLogFile=$out/slurmctld.log
SlurmdLogFile=$out/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=pmix
ReturnToService=2
KillWait=30
$(slurmd -C | head -n 1) State=UNKNOWN
PartitionName=check Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$out/slurm.conf
cleanup() {
  for p in slurmd slurmctld; do [ -s "$out/$p.pid" ] && kill "$(cat "$out/$p.pid")" 2> /dev/null || true; done
  [ -z "${started_munge:-}" ] || pkill -x munged || true
}
trap cleanup EXIT
slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF"
for _ in $(seq 60); do sinfo -h -o %T 2> /dev/null | grep -qx idle && break; sleep 1; done
sinfo -h -o %T | grep -qx idle || fail "the node is not idle: $(sinfo 2>&1 | tail -2)"
echo "slurm $(sinfo -V | cut -d' ' -f2): one node ($host), srun --mpi=list: $(srun --mpi=list 2>&1 | grep -o 'pmix[_a-z0-9]*' | sort -u | tr '\n' ' ')"

cd "$out/runs"
train=(train "$data/lego" --preset tiny --downscale 8 --seed 1 --every 100 --batch 1000)
"$mcnerf" "${train[@]}" -o one.ckpt --iters 12 --threads 2 > one.log 2>&1 || fail "one process: $(tail -3 one.log)"
for n in 2 3; do
  srun -n $n -O --mpi=pmix "$mcnerf" "${train[@]}" -o s$n.ckpt --iters 12 --threads 1 > s$n.log 2>&1 ||
    fail "srun -n $n: $(tail -5 s$n.log)"
  cmp -s one.ckpt s$n.ckpt || fail "srun -n $n: the checkpoint differs from one process's"
  [ "$(grep -c "^saved s$n.ckpt" s$n.log)" = 1 ] || fail "srun -n $n: not one log: $(tail -5 s$n.log)"
  echo "srun -n $n -O --mpi=pmix: the checkpoint of one process ($(md5sum < one.ckpt | cut -c1-32))"
done

# scancel: SIGTERM to every rank (plain scancel: SIGTERM, then SIGKILL after KillWait).
stop_with() { # NAME SCANCEL-ARGS...
  local name=$1; shift
  srun -n 2 -O --mpi=pmix -J "$name" "$mcnerf" "${train[@]}" -o "$name.ckpt" --iters 100000 \
    --ckpt-secs 1000000 --threads 1 --log-every 2 > "$name.log" 2>&1 &
  local pid=$!
  for _ in $(seq 600); do grep -q "iter 6/" "$name.log" 2> /dev/null && break; sleep 0.5; done
  local job; job=$(squeue -h -n "$name" -o %i | head -n 1)
  [ -n "$job" ] || fail "$name: no job"
  local t0; t0=$(date +%s.%N)
  scancel "$@" "$job"
  local rc=0; wait $pid || rc=$?
  [ $rc = 143 ] || fail "scancel $*: srun exited $rc, not 143: $(tail -5 "$name.log")"
  grep -q "^interrupted by SIGTERM: saved $name.ckpt at iteration" "$name.log" ||
    fail "scancel $*: no checkpoint saved: $(tail -5 "$name.log")"
  echo "scancel $*: $(grep "^interrupted" "$name.log" | cut -d: -f1-2), exit 143 after $(printf %.1f "$(echo "$(date +%s.%N) - $t0" | bc)") s"
}
stop_with term --signal=TERM
stop_with cancel
it=$(sed -n 's/^interrupted by SIGTERM: saved term.ckpt at iteration \([0-9]*\).*/\1/p' term.log)
cp term.ckpt term1.ckpt
"$mcnerf" "${train[@]}" -o term1.ckpt --resume --iters $((it + 4)) --threads 2 > res1.log 2>&1 ||
  fail "resume: $(tail -3 res1.log)"
srun -n 2 -O --mpi=pmix "$mcnerf" "${train[@]}" -o term.ckpt --resume --iters $((it + 4)) --threads 1 \
  > res2.log 2>&1 || fail "srun --resume: $(tail -5 res2.log)"
cmp -s term1.ckpt term.ckpt || fail "resumed on 2 ranks: differs from one process's"
echo "resumed on 2 ranks from iteration $it: as one process"

# A rank killed: what Slurm does (printed).
srun -n 2 -O --mpi=pmix -J dead "$mcnerf" "${train[@]}" -o dead.ckpt --iters 100000 --threads 1 --log-every 2 \
  --ckpt-every 4 > dead.log 2>&1 &
pid=$!
for _ in $(seq 600); do grep -q "iter 10/" dead.log 2> /dev/null && break; sleep 0.5; done
victim=""
for p in $(pgrep -f "cnerf train .*dead.ckpt"); do
  tr '\0' '\n' < /proc/$p/environ 2> /dev/null | grep -qx "SLURM_PROCID=1" && victim=$p
done
[ -n "$victim" ] || fail "no rank 1 to kill"
t0=$(date +%s.%N)
kill -KILL "$victim"
rc=0; wait $pid || rc=$?
echo "rank 1 killed: srun exited $rc after $(printf %.1f "$(echo "$(date +%s.%N) - $t0" | bc)") s; its lines:"
grep -v "^iter" dead.log | sed 's/^/  /'
"$mcnerf" "${train[@]}" -o dead.ckpt --resume --iters 13 --threads 2 > dead-res.log 2>&1 ||
  fail "the checkpoint of a job with a killed rank does not resume: $(tail -3 dead-res.log)"
echo "  $(grep resumed dead-res.log)"
echo "OK"
