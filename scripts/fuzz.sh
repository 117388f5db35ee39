#!/usr/bin/env bash
# Runs every libFuzzer harness (tests/fuzz/fuzz_*.c) in turn under AddressSanitizer and
# UndefinedBehaviorSanitizer for SECONDS each (60), starting from its saved corpus
# (tests/fuzz/corpus/NAME/), then merges the inputs that reach new coverage into that corpus
# (-merge=1: the saved corpus only grows by what adds coverage). Prints, per harness, the
# executions, the corpus before and after, and the result; a crashing input is copied to
# tests/crashers/NAME-<sha1> and the script exits 1.
#
#   scripts/fuzz.sh [SECONDS] [--jobs J] [--only NAME]
#
# Environment: FUZZ_BUILD_DIR (build-fuzz), FUZZ_MAX_LEN (4096), FUZZ_LOG (a file to which a
# line per harness is appended: date, commit, harness, seconds, executions, result).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
secs=60 jobs=1 only=""
while [ $# -gt 0 ]; do
  case $1 in
    --jobs) jobs=$2; shift ;;
    --only) only=$2; shift ;;
    [0-9]*) secs=$1 ;;
    *) sed -n '2,13p' "$0" >&2; exit 2 ;;
  esac
  shift
done
[[ $secs =~ ^[0-9]+$ && $secs -gt 0 && $jobs =~ ^[0-9]+$ && $jobs -gt 0 ]] ||
  { echo "fuzz.sh: SECONDS and --jobs take positive integers" >&2; exit 2; }
command -v clang > /dev/null || { echo "fuzz.sh: clang is missing: apt-get install clang libclang-rt-14-dev" >&2; exit 1; }

bdir=${FUZZ_BUILD_DIR:-$root/build-fuzz}
max_len=${FUZZ_MAX_LEN:-4096}
mkdir -p "$bdir"
CC=clang cmake -S "$root" -B "$bdir" -DCNERF_FUZZ=ON -DCNERF_BUILD_ENCODER=OFF \
  -DCNERF_BUILD_TESTS=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo > "$bdir/fuzz-cmake.log" 2>&1 ||
  { echo "fuzz.sh: cmake failed (log: $bdir/fuzz-cmake.log)" >&2; exit 1; }
cmake --build "$bdir" -j2 > "$bdir/fuzz-build.log" 2>&1 ||
  { echo "fuzz.sh: build failed (log: $bdir/fuzz-build.log)" >&2; exit 1; }

commit=$(git -C "$root" rev-parse --short HEAD 2> /dev/null || echo unknown)
status=0 total=0
for src in "$root"/tests/fuzz/fuzz_*.c; do
  name=$(basename "$src" .c); name=${name#fuzz_}
  [ -z "$only" ] || [ "$only" = "$name" ] || continue
  bin=$bdir/tests/fuzz/fuzz_$name
  corpus=$root/tests/fuzz/corpus/$name
  mkdir -p "$corpus"
  work=$(mktemp -d)
  cp "$corpus"/* "$work"/ 2> /dev/null || true
  before=$(find "$corpus" -type f | wc -l)
  log=$work.log
  par=()
  [ "$jobs" -eq 1 ] || par=(-jobs="$jobs" -workers="$jobs")
  set +e
  (cd "$(dirname "$work")" && "$bin" -max_total_time="$secs" -max_len="$max_len" \
    -print_final_stats=1 "${par[@]}" -artifact_prefix="$work.crash-" "$work" > "$log" 2>&1)
  rc=$?
  set -e
  # executions: the final stats of every worker (with -jobs, each writes fuzz-N.log)
  wdir=$(dirname "$work")
  execs=$({ cat "$log"; cat "$wdir"/fuzz-*.log 2> /dev/null || true; } |
          sed -n 's/^stat::number_of_executed_units: *//p' | awk '{s += $1} END {print s + 0}')
  rm -f "$wdir"/fuzz-*.log
  result=ok
  crash=$(ls "$work".crash-* 2> /dev/null | head -1 || true)
  if [ $rc -ne 0 ] || [ -n "$crash" ]; then
    result="FAILED (exit $rc)"
    status=1
    if [ -n "$crash" ]; then
      sum=$(sha1sum "$crash" | cut -c1-12)
      mkdir -p "$root/tests/crashers"
      cp "$crash" "$root/tests/crashers/$name-$sum"
      result="$result: input saved as tests/crashers/$name-$sum"
    fi
    tail -30 "$log" >&2
  else
    "$bin" -merge=1 -max_len="$max_len" "$corpus" "$work" > "$log.merge" 2>&1 ||
      { echo "fuzz.sh: merging into $corpus failed (log: $log.merge)" >&2; status=1; }
  fi
  after=$(find "$corpus" -type f | wc -l)
  total=$((total + execs))
  printf 'fuzz %-8s %7d s  %12d executions  corpus %d -> %d  %s\n' "$name" "$secs" "$execs" \
    "$before" "$after" "$result"
  [ -z "${FUZZ_LOG:-}" ] ||
    printf '%s %s %s %d %d %s\n' "$(date -u +%Y-%m-%dT%H:%MZ)" "$commit" "$name" "$secs" "$execs" \
      "$result" >> "$FUZZ_LOG"
  rm -rf "$work" "$work".crash-* "$log" "$log.merge"
done
echo "fuzz: $total executions in all, commit $commit"
exit $status
