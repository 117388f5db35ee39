#!/usr/bin/env bash
# Byte identity of the encoder's outputs across a change that must not alter them (a
# restructuring): runs a fixed set of commands at fixed seeds and thread counts and prints
# each written file's MD5. Run it before and after; the two listings must be equal.
#   tools/identity.sh OUT [CNERF]      (CNERF: the binary, default ./build/cnerf)
# Runs repeat bit for bit only at the same seed and thread count (docs/training.md), so each
# command fixes --threads. About ten minutes on a 2-core machine.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: identity.sh OUT [CNERF]}
cnerf=$(realpath "${2:-./build/cnerf}")
data=$(realpath "${CNERF_DATA:-../shared/data}")
mkdir -p "$out"
# The files' metadata names the inputs' paths: run inside OUT with the same relative names, so
# that two listings made in different directories compare.
cd "$out"
out=.
rm -f ./*.cnrf ./*.ckpt
run() { local name=$1; shift; echo "== $name: cnerf $*" >&2; "$cnerf" "$@" > "$name.log" 2>&1; }
# The README main job (scripts/demo.sh's encode).
run main encode "$data/lego" -o "$out/main.cnrf" --lambda 0.1 --preset tiny --downscale 4 \
  --iters 2000 --every 40 --log-every 100 --threads 2
# A byte budget on Fern (rate control, the default preset choice: the rule, in a run this short).
run fern encode "$data/fern" -o "$out/fern.cnrf" --size 20000 --iters 400 --max-size 64 \
  --threads 2 --seed 3
# Two scenes in one stream (shared shifts).
run set encode "$data/lego" "$data/mic" -o "$out/set.cnrf" --lambda 1e-3 --iters 200 \
  --downscale 8 --threads 2 --every 100
# A float model, then the baseline quantizer and an encode from it (--init).
run float train "$data/lego" -o "$out/float.ckpt" --preset tiny --iters 200 --downscale 8 \
  --threads 2
run quant quantize "$out/float.ckpt" -o "$out/quant.cnrf" --bits 8
run init encode "$data/lego" -o "$out/init.cnrf" --init "$out/float.ckpt" --lambda 1e-2 \
  --preset tiny --iters 100 --downscale 8 --threads 2 --every 100
# Synthetic streams: a plain one, one with a grid, pruned units and a set.
run synth synth -o "$out/synth.cnrf" --preset tiny --seed 5
run synthg synth -o "$out/synthg.cnrf" --preset tiny --seed 6 --grid 32 --units 40,30,50,20:20
run synths synth -o "$out/synths.cnrf" --preset tiny --seed 7 --scenes 2
md5sum ./*.cnrf ./*.ckpt
