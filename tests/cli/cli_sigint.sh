#!/usr/bin/env bash
# Ctrl-C pressed over and over during training (tests/tools/sigstorm: a SIGINT every 200 us
# from the first progress line on): cnerf train and encode must save a checkpoint that
# loads, say so and exit with status 130, however many signals land inside the matrix
# products or during the save. oneDNN's x64 GEMM kernels point the stack pointer into the
# heap while they run, so a signal handler that runs on one of their threads corrupts the
# heap (an abort in the next malloc or free).
set -euo pipefail
cnerf=$1 data=$2 work=$3 sigstorm=$4
rm -rf "$work" && mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }
common=(--preset small --downscale 8 --batch 2048 --iters 100000 --log-every 1 --threads 2)

for round in 1 2; do
  for cmd in train encode; do
    out="$work/$cmd$round"
    extra=()
    [ $cmd = encode ] && extra=(--lambda 1)
    set +e
    "$sigstorm" "iter " 200 30000 -- "$cnerf" $cmd "$data/lego" -o "$out.x" "${common[@]}" \
      "${extra[@]}" > "$out.log" 2> "$out.err"
    rc=$?
    set -e
    [ $rc -eq 130 ] || fail "$cmd round $round exited $rc, want 130: $(tail -5 "$out.err")"
    ckpt="$out.x"
    [ $cmd = encode ] && ckpt="$out.x.ckpt"
    grep -q "^interrupted: saved $ckpt at iteration [1-9]" "$out.log" ||
      fail "$cmd round $round: no save: $(tail -3 "$out.log")"
    "$cnerf" eval "$ckpt" "$data/lego" --downscale 8 --every 200 > "$out.eval" ||
      fail "$cmd round $round: the checkpoint does not load"
    echo "$cmd round $round: $(grep -o 'saved .* at iteration [0-9]*' "$out.log"), $(cat "$out.err")"
  done
done
