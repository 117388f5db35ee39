#!/usr/bin/env bash
# ctests check_kernels_m4, _m7, _m33, _m55, _m0plus: check_kernels
# (tests/xarch/check_kernels.c) as bare-metal firmware for the core FW_CORE names (m4, m7,
# m33: the DSP extension's kernels; m55: Helium's; m0plus: the portable C alone; FW_BOARD
# an386 or an547 is m4 or m55, as in scripts/firmware.sh), run under qemu-system-arm; every
# kernel set of the core must give the portable C's values.
#   [FW_CORE=m4|m7|m33|m55|m0plus] check_kernels.sh BUILD_DIR
set -euo pipefail
build=$1
root=$(cd "$(dirname "$0")/../.." && pwd)
case ${FW_CORE:-${FW_BOARD:-m4}} in
  m4|an386) board=an386 machine=mps2-an386 toolchain=arm-none-eabi.cmake ;;
  m7) board=an500 machine=mps2-an500 toolchain=arm-none-eabi-m7.cmake ;;
  m33) board=an505 machine=mps2-an505 toolchain=arm-none-eabi-m33.cmake ;;
  m55|an547) board=an547 machine=mps3-an547 toolchain=arm-none-eabi-m55.cmake ;;
  m0plus) board=an386 machine=mps2-an386 toolchain=arm-none-eabi-m0plus.cmake ;;
  *) echo "check_kernels.sh: FW_CORE must be m4, m7, m33, m55 or m0plus" >&2; exit 2 ;;
esac
cmake -S "$root" -B "$build" -DCMAKE_TOOLCHAIN_FILE="$root/cmake/toolchains/$toolchain" \
  -DCMAKE_BUILD_TYPE=MinSizeRel -DCNERF_FW_BOARD="$board" > /dev/null
cmake --build "$build" --target check_kernels_fw > /dev/null
out=$(timeout 1200 qemu-system-arm -M "$machine" -nographic \
        -semihosting-config enable=on,target=native \
        -kernel "$build/platform/cortex-m/check_kernels_fw.elf" < /dev/null 2>&1) && rc=0 || rc=$?
echo "$out"
grep -q " passed, 0 failed" <<<"$out" && [ "$rc" = 0 ] ||
  { echo "FAIL: check_kernels on $machine (exit $rc)"; exit 1; }
