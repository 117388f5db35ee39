#!/usr/bin/env bash
# Freestanding Cortex-M4 build of the decoder: -std=c99 -ffreestanding -nostdlib, linked with
# a minimal entry point and nothing else. Prints code/data sizes and the worst-case stack.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build-m4 -DCMAKE_TOOLCHAIN_FILE=cmake/toolchains/arm-none-eabi.cmake \
      -DCMAKE_BUILD_TYPE=MinSizeRel
cmake --build build-m4 --clean-first
