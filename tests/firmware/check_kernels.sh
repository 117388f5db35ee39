#!/usr/bin/env bash
# ctests check_kernels_m4, check_kernels_m55: check_kernels (tests/xarch/check_kernels.c) as
# bare-metal firmware for the board FW_BOARD names (an386: Cortex-M4, the DSP extension's
# kernels; an547: Cortex-M55, Helium's), run under qemu-system-arm; every kernel set of the
# core must give the portable C's values.
#   [FW_BOARD=an386|an547] check_kernels.sh BUILD_DIR
set -euo pipefail
build=$1
root=$(cd "$(dirname "$0")/../.." && pwd)
case ${FW_BOARD:-an386} in
  an386) machine=mps2-an386 toolchain=arm-none-eabi.cmake ;;
  an547) machine=mps3-an547 toolchain=arm-none-eabi-m55.cmake ;;
  *) echo "check_kernels.sh: FW_BOARD must be an386 or an547" >&2; exit 2 ;;
esac
cmake -S "$root" -B "$build" -DCMAKE_TOOLCHAIN_FILE="$root/cmake/toolchains/$toolchain" \
  -DCMAKE_BUILD_TYPE=MinSizeRel -DCNERF_FW_BOARD="${FW_BOARD:-an386}" > /dev/null
cmake --build "$build" --target check_kernels_fw > /dev/null
out=$(timeout 1200 qemu-system-arm -M "$machine" -nographic \
        -semihosting-config enable=on,target=native \
        -kernel "$build/platform/cortex-m/check_kernels_fw.elf" < /dev/null 2>&1) && rc=0 || rc=$?
echo "$out"
grep -q " passed, 0 failed" <<<"$out" && [ "$rc" = 0 ] ||
  { echo "FAIL: check_kernels on $machine (exit $rc)"; exit 1; }
