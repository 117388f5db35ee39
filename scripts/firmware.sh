#!/usr/bin/env bash
# The decoder as bare-metal firmware on an emulated Cortex-M4 (QEMU's mps2-an386 board) or
# another core (FW_CORE below: M0+, M7, M33, M55): builds platform/cortex-m's
# cnerf_fw.elf with STREAM, CAMERA, the tile and the knobs embedded, runs it under
# qemu-system-arm with semihosting, renders the same tile on the host with
# tests/xarch/render_tile.c, prints both MD5s and exits 0 only if they are equal.
# Then reports what the firmware costs on the target: flash, RAM, worst-case stack and
# instructions per ray.
#
#   scripts/firmware.sh STREAM CAMERA "X0 Y0 W H" [N_COARSE N_FINE T_STOP [FLAGS]]
#   scripts/firmware.sh --jobs JOBS
#
# The second form builds one image that renders a batch of tiles, one after another, and
# checks each the same way; JOBS has one line per tile (platform/cortex-m/fw_embed.c):
#   NAME EXPECT_MD5|- STREAM SCENE CAMERA CAMNAME|- X0 Y0 W H [N_COARSE N_FINE T_STOP [FLAGS]]
# It prints the image's memory and stack, then one line per job: its MD5 and instructions
# per ray. Streams are embedded once each, however many jobs use them.
#
# CAMERA is the text file tests/xarch/render_tile.c reads (18 integers); T_STOP is Q30, as
# there; FLAGS is cnerf_render_opts.flags (1: CNERF_RENDER_NO_SKIP, ignore the stream's
# occupancy grid). Environment:
#   FW_CORE        the core and its board under QEMU:
#                  m4 (default): MPS2 AN386, Cortex-M4, -mcpu=cortex-m4 -mfloat-abi=soft;
#                  m7: MPS2 AN500, Cortex-M7, -mcpu=cortex-m7 -mfloat-abi=soft;
#                  m33: MPS2 AN505, Cortex-M33, -mcpu=cortex-m33 -mfloat-abi=soft;
#                  m55: MPS3 AN547, Cortex-M55, -mcpu=cortex-m55 -mfloat-abi=softfp (FPU
#                  and MVE usable, the soft-float calling convention);
#                  m0plus: Cortex-M0+ code (-mcpu=cortex-m0plus, Armv6-M, libgcc's integer
#                  helpers) on the AN386, whose Cortex-M4 runs it: QEMU has no M0-class
#                  board with the RAM a stream needs. Its instructions are the M0+'s
#                  instructions, not its cycles
#   FW_BOARD       the older name of the choice: an386 is m4, an547 is m55
#   FW_BUILD_DIR   build directory, one per core (build-fw, build-fw-m7, build-fw-m33,
#                  build-fw-an547, build-fw-m0plus)
#   FW_BUILD_TYPE  MinSizeRel (default): -Os, the configuration scripts/build-m4.sh measures
#                  and docs/decoder.md states (code size, stack), and the one a flash-bound
#                  part would ship; Release (-O3) has 2.5x the code for ~12% fewer
#                  instructions per ray
#   FW_STACK       bytes reserved for the stack (4096); the static worst case must fit
#   FW_TIMEOUT     seconds before QEMU is killed (600)
#   FW_EXPECT_MD5  if set, the MD5 the tile must also have (a golden value)
#   FW_SCENE       the scene of a stream of several that the firmware opens (0)
#   FW_AMALGAMATED 1: the decoder from scripts/amalgamate.sh's single file (cnerf_decoder.c)
#   FW_PACK        a kernel set (dsp for the M4, M7, M33; mve for the M55; c for the M0+):
#                  each tile's stream is embedded as its packed image for that set (cnerf
#                  pack), which the firmware opens in place in flash (cnerf_open_packed), with
#                  no workspace in RAM; the MD5s must be the stream's
#   FW_FAST        1: the workspace sized by cnerf_workspace_size_fast, so that the decoder
#                  keeps every latent as int16 (faster int8-range layers on the DSP cores,
#                  more RAM); streams only, not with FW_PACK
#   FW_LEVEL       a level (1..3): the decoder built with CNERF_MAX_LEVEL, its workspace and
#                  scratch the level's (CNERF_LEVEL_WORKSPACE, CNERF_LEVEL_SCRATCH), whatever
#                  the streams need; a stream above the level fails to open
#   FW_WORK        0: no second, untimed render of each tile to count its work (evaluations,
#                  MACs): half the run, for a check that needs only the MD5s; first: the
#                  first job's work only (the check that the host's count, which the cost
#                  model uses, is the firmware's); 1 (default): every tile's
#   FW_HOST_TILE   the host program that renders each tile beside the firmware, already
#                  built (ctest passes the build's render_tile_cost); without it this script
#                  builds tests/xarch/render_tile.c into the build directory
#   FW_PROFILE     a file: the firmware is run once more under QEMU's execution trace
#                  (-d in_asm,exec,nochain, into a temporary file of about 70 bytes an
#                  executed block: keep the tile small) and FILE gets the instructions
#                  executed per function from the first call of cnerf_render_tile on
#                  (scripts/fw_profile.py; the firmware's own printing and MD5 among them)
# Instructions are counted with QEMU's -icount shift=0 (one virtual nanosecond per
# instruction) and the SysTick on the processor clock (25 MHz on the AN386, 32 MHz on the
# AN547): 40 or 31.25 instructions per tick, validated by the firmware on a loop of known
# length (see platform/cortex-m/fw_render.c).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
if [ "${1:-}" = "--jobs" ] && [ $# -eq 2 ]; then
  jobs_in=$2
elif [ $# -ne 3 ] && [ $# -ne 6 ] && [ $# -ne 7 ]; then
  sed -n '2,/^set -euo/{/^set/!p}' "$0" >&2
  exit 2
fi
case ${FW_CORE:-${FW_BOARD:-m4}} in
  # core, its kernel set, board, QEMU machine, toolchain file, default build directory, second counter
  m4|an386) core=Cortex-M4 set=dsp board=an386 machine=mps2-an386
            toolchain=cmake/toolchains/arm-none-eabi.cmake bdir_default=build-fw
            timer2="APB timer0" ;;
  m7) core=Cortex-M7 set=dsp board=an500 machine=mps2-an500
      toolchain=cmake/toolchains/arm-none-eabi-m7.cmake bdir_default=build-fw-m7
      timer2="APB timer0" ;;
  m33) core=Cortex-M33 set=dsp board=an505 machine=mps2-an505
       toolchain=cmake/toolchains/arm-none-eabi-m33.cmake bdir_default=build-fw-m33
       timer2="IoT Kit timer0" ;;
  m55|an547) core=Cortex-M55 set=mve board=an547 machine=mps3-an547
             toolchain=cmake/toolchains/arm-none-eabi-m55.cmake bdir_default=build-fw-an547
             timer2="SSE-300 system counter" ;;
  m0plus) core=Cortex-M0+ set=c board=an386 machine=mps2-an386
          toolchain=cmake/toolchains/arm-none-eabi-m0plus.cmake bdir_default=build-fw-m0plus
          timer2="APB timer0" ;;
  *) echo "firmware.sh: FW_CORE must be m4, m7, m33, m55 or m0plus, not" \
          "'${FW_CORE:-${FW_BOARD:-}}'" >&2; exit 2 ;;
esac
if [ -z "${jobs_in:-}" ]; then
  stream=$1 camera=$2 tile=$3
  knobs=""
  [ $# -ge 6 ] && knobs="$4 $5 $6"
  [ $# -eq 7 ] && knobs="$knobs $7"
  for f in "$stream" "$camera"; do
    [ -f "$f" ] || { echo "firmware.sh: $f: no such file" >&2; exit 2; }
  done
  stream=$(realpath "$stream") camera=$(realpath "$camera")
  read -r x0 y0 w h extra <<< "$tile" || true
  if [ -z "${h:-}" ] || [ -n "${extra:-}" ]; then
    echo "firmware.sh: the tile must be \"X0 Y0 W H\", not \"$tile\"" >&2
    exit 2
  fi
  for v in $x0 $y0 $w $h $knobs; do
    [[ $v =~ ^[0-9]+$ ]] || { echo "firmware.sh: $v: not a non-negative integer" >&2; exit 2; }
  done
  [[ ${FW_SCENE:-0} =~ ^[0-9]+$ ]] || { echo "firmware.sh: FW_SCENE must be a scene index" >&2; exit 2; }
  [[ -z ${FW_EXPECT_MD5:-} || ${FW_EXPECT_MD5} =~ ^[0-9a-f]{32}$ ]] ||
    { echo "firmware.sh: FW_EXPECT_MD5 must be 32 hex digits" >&2; exit 2; }
  job="tile ${FW_EXPECT_MD5:--} $stream ${FW_SCENE:-0} $camera - $x0 $y0 $w $h $knobs"
else
  [ -f "$jobs_in" ] || { echo "firmware.sh: $jobs_in: no such file" >&2; exit 2; }
  # The jobs with absolute paths (a relative one is the job file's directory's), each file
  # checked
  job="" jdir=$(dirname "$(realpath "$jobs_in")") lineno=0
  while read -r -a w; do
    lineno=$((lineno + 1))
    [ ${#w[@]} -eq 0 ] || [[ ${w[0]} == \#* ]] && continue
    if [ ${#w[@]} -ne 10 ] && [ ${#w[@]} -ne 13 ] && [ ${#w[@]} -ne 14 ]; then
      echo "firmware.sh: $jobs_in:$lineno: a job is NAME EXPECT STREAM SCENE CAMERA CAMNAME X0 Y0 W H [N_COARSE N_FINE T_STOP [FLAGS]]" >&2
      exit 2
    fi
    for i in 2 4; do
      [[ ${w[$i]} == /* ]] || w[$i]=$jdir/${w[$i]}
      [ -f "${w[$i]}" ] || { echo "firmware.sh: $jobs_in:$lineno: ${w[$i]}: no such file" >&2; exit 2; }
    done
    job+="${w[*]}"$'\n'
  done < "$jobs_in"
  [ -n "$job" ] || { echo "firmware.sh: $jobs_in: no jobs" >&2; exit 2; }
fi

need() { # program, Debian package
  command -v "$1" > /dev/null ||
    { echo "firmware.sh: $1 is missing: apt-get install $2" >&2; exit 1; }
}
need cmake cmake
need cc gcc
need arm-none-eabi-gcc gcc-arm-none-eabi
need arm-none-eabi-size binutils-arm-none-eabi
need arm-none-eabi-nm binutils-arm-none-eabi
need qemu-system-arm qemu-system-arm
need timeout coreutils
need md5sum coreutils
need python3 python3
if ! grep -q "^$machine " <<< "$(qemu-system-arm -machine help)"; then
  echo "firmware.sh: this qemu-system-arm has no $machine machine (QEMU 7.2: apt-get install qemu-system-arm)" >&2
  exit 1
fi

cd "$root"
bdir=${FW_BUILD_DIR:-$bdir_default}
btype=${FW_BUILD_TYPE:-MinSizeRel}
stack=${FW_STACK:-4096}
tmo=${FW_TIMEOUT:-600}
mkdir -p "$bdir"
bdir=$(realpath "$bdir")
log=$bdir/firmware-build.log
jobs=$bdir/jobs.txt
printf '%s\n' "$job" | sed '/^$/d' > "$jobs.new"
# rewritten only when it changes, so that an unchanged batch is not embedded again
if cmp -s "$jobs.new" "$jobs"; then rm "$jobs.new"; else mv "$jobs.new" "$jobs"; fi

# ---- the firmware ----
case ${FW_FAST:-0} in
  0) fw_fast=OFF ;;
  1) fw_fast=ON ;;
  *) echo "firmware.sh: FW_FAST must be 0 or 1, not '$FW_FAST'" >&2; exit 2 ;;
esac
[ "$fw_fast" = OFF ] || [ -z "${FW_PACK:-}" ] ||
  { echo "firmware.sh: FW_FAST is for streams decoded into RAM, not with FW_PACK" >&2; exit 2; }
case ${FW_WORK:-1} in
  0) fw_work=OFF fw_work_first=OFF ;;
  first) fw_work=ON fw_work_first=ON ;;
  1) fw_work=ON fw_work_first=OFF ;;
  *) echo "firmware.sh: FW_WORK must be 0, first or 1, not '$FW_WORK'" >&2; exit 2 ;;
esac
if ! { cmake -S . -B "$bdir" -DCMAKE_TOOLCHAIN_FILE="$toolchain" -DCNERF_FW_BOARD="$board" \
         -DCMAKE_BUILD_TYPE="$btype" -DCNERF_FW_JOBS="$jobs" -DCNERF_FW_STACK="$stack" \
         -DCNERF_AMALGAMATED="${FW_AMALGAMATED:-0}" -DCNERF_FW_WORK="$fw_work" \
         -DCNERF_FW_WORK_FIRST="$fw_work_first" -DCNERF_FW_PACK="${FW_PACK:-}" \
         -DCNERF_MAX_LEVEL="${FW_LEVEL:-0}" -DCNERF_FW_FAST="$fw_fast" &&
       cmake --build "$bdir" -j1 --target cnerf_fw; } > "$log" 2>&1; then
  cat "$log" >&2
  echo "firmware.sh: the firmware build failed (log: $log)" >&2
  exit 1
fi
grep 'cnerf_fw_embed: warning' "$log" >&2 || true
elf=$bdir/platform/cortex-m/cnerf_fw.elf
echo "built $elf ($core, $board, $btype, $(arm-none-eabi-gcc -dumpversion))"

out=$bdir/firmware.out
set +e
timeout "$tmo" qemu-system-arm -M "$machine" -nographic \
  -semihosting-config enable=on,target=native -icount shift=0 -kernel "$elf" \
  < /dev/null > "$out" 2>&1
rc=$?
set -e
if [ $rc -eq 124 ]; then
  cat "$out" >&2
  echo "firmware.sh: the firmware did not finish within $tmo s (FW_TIMEOUT)" >&2
  exit 1
fi
if [ $rc -ne 0 ] || ! grep -q '^fw stack ' "$out"; then
  cat "$out" >&2
  echo "firmware.sh: the firmware failed (exit status $rc)" >&2
  exit 1
fi

if [ -n "${FW_PROFILE:-}" ]; then
  trace=$(mktemp "$bdir/trace.XXXXXX")
  timeout "$tmo" qemu-system-arm -M "$machine" -nographic \
    -semihosting-config enable=on,target=native -icount shift=0 -kernel "$elf" \
    -d in_asm,exec,nochain -D "$trace" < /dev/null > /dev/null 2>&1 ||
    { rm -f "$trace"; echo "firmware.sh: the traced run failed" >&2; exit 1; }
  python3 "$root/scripts/fw_profile.py" "$trace" cnerf_render_tile > "$FW_PROFILE" ||
    { rm -f "$trace"; exit 1; }
  rm -f "$trace"
  echo "profile (instructions per function, FW_PROFILE): $FW_PROFILE"
fi

# ---- the same tile on the host ----
# (FW_HOST_TILE: that program already built, as the build's render_tile_cost)
host=${FW_HOST_TILE:-$bdir/render_tile_host}
host_src=(decoder/*.c decoder/*.h common/*.h include/cnerf/*.h platform/host/cost_model.[ch]
          tests/xarch/render_tile.c)
[ -z "${FW_HOST_TILE:-}" ] || [ -x "$host" ] ||
  { echo "firmware.sh: FW_HOST_TILE=$host: no such program" >&2; exit 2; }
if [ -z "${FW_HOST_TILE:-}" ] &&
   { [ ! -x "$host" ] || [ -n "$(find "${host_src[@]}" -newer "$host" 2>/dev/null | head -n 1)" ]; }; then
  cc -std=c99 -O2 -Wall -Wextra -Werror -Iinclude -Iplatform/host -DCNERF_COST_MODEL \
    decoder/*.c platform/host/cost_model.c tests/xarch/render_tile.c -o "$host"
fi
python3 "$root/scripts/fw_report.py" "$root" "$bdir" "$elf" "$out" "$jobs" "$host" "$btype" \
  "$core" "$set" "$timer2" "$([ -n "${jobs_in:-}" ] && echo jobs || echo tile)"
if [ -z "${jobs_in:-}" ]; then
  echo "firmware.sh: OK: the firmware's tile has the host's MD5 $(sed -n 's/^md5 //p' "$out")"
else
  echo "firmware.sh: OK: $(grep -c '^md5 ' "$out") tiles, each with the host's MD5 and the one its job expects"
fi
