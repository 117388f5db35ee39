#!/usr/bin/env bash
# The main job on the bundled default: encode the shared Lego scene (100x100, preset tiny)
# into out/lego.cnrf, read it back and render its test views (r_0, r_40, ... r_160) with the
# float reference of the file, print the stream's size breakdown, then decode the file with
# the fixed-point decoder and render the same views into out/render/ (PSNR against the ground
# truth and against the float reference, time per frame).
# DEMO_ITERS sets the training iterations (default 2000: about 71 s of training on a 2-core
# machine, 25.3 dB on the five test views and 25.8 dB on the 100 validation views;
# docs/training.md).
set -euo pipefail
cd "$(dirname "$0")/.."
data=${CNERF_DATA:-../shared/data}
mkdir -p out
rm -f out/lego.cnrf.ckpt # the demo starts afresh each time it runs
cmake -S . -B build -DCMAKE_BUILD_TYPE=RelWithDebInfo
cmake --build build -j"$(nproc 2>/dev/null || echo 2)"
./build/cnerf encode "$data/lego" -o out/lego.cnrf --lambda 0.1 --preset tiny --downscale 4 \
  --iters "${DEMO_ITERS:-2000}" --every 40 --log-every 100
./build/cnerf info out/lego.cnrf
./build/cnerf render out/lego.cnrf --dataset "$data/lego" --downscale 4 --every 40 -o out/render
