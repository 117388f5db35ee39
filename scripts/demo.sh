#!/usr/bin/env bash
# The main job on the bundled default. Until the encoder lands: write a synthetic model of
# the embedded receiver's size ("tiny") and print its size breakdown.
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p out
cmake -S . -B build -DCMAKE_BUILD_TYPE=RelWithDebInfo
cmake --build build -j"$(nproc 2>/dev/null || echo 2)"
./build/cnerf synth -o out/tiny-synth.cnrf --preset tiny --seed 1
./build/cnerf info out/tiny-synth.cnrf
