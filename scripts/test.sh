#!/usr/bin/env bash
# Builds cnerf and runs every test with ctest.
#   scripts/test.sh              RelWithDebInfo build in build/
#   scripts/test.sh --sanitize   the same under AddressSanitizer + UBSan in build-asan/, less
#                                the firmware tests (cross-built firmware under qemu-system,
#                                not the host code the sanitizers instrument) and the tests of
#                                the experiment scripts (label "experiment": they drive the
#                                train and encode commands that cli_train already runs
#                                instrumented), the web tests (label "web": the
#                                WebAssembly decoder under Node and Chromium), the MPI
#                                test (label "mpi": it builds its own configuration, not
#                                the instrumented one) and cli_threads (label "determinism":
#                                the same encodes on 1, 2 and 3 threads, whose passes
#                                test_train's test_threads_agree runs instrumented)
set -euo pipefail
cd "$(dirname "$0")/.."
build=build
opts=()
skip=()
if [ "${1:-}" = "--sanitize" ]; then
  build=build-asan
  opts=(-DCNERF_SANITIZE=ON)
  skip=(-LE 'firmware|experiment|web|mpi|determinism')
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1
fi
jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo "${opts[@]}"
cmake --build "$build" -j"$jobs"
ctest --test-dir "$build" --output-on-failure -j"$jobs" "${skip[@]}"
