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
# Instructions are counted with QEMU's -icount shift=0 (one virtual nanosecond per
# instruction) and the SysTick on the processor clock (25 MHz on the AN386, 32 MHz on the
# AN547): 40 or 31.25 instructions per tick, validated by the firmware on a loop of known
# length (see platform/cortex-m/fw_render.c).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
if [ $# -ne 3 ] && [ $# -ne 6 ] && [ $# -ne 7 ]; then
  sed -n '2,29p' "$0" >&2
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
log=$bdir/firmware-build.log

# ---- the firmware ----
if ! { cmake -S . -B "$bdir" -DCMAKE_TOOLCHAIN_FILE="$toolchain" -DCNERF_FW_BOARD="$board" \
         -DCMAKE_BUILD_TYPE="$btype" -DCNERF_FW_STREAM="$stream" -DCNERF_FW_CAMERA="$camera" \
         -DCNERF_FW_TILE="$x0 $y0 $w $h" -DCNERF_FW_KNOBS="$knobs" -DCNERF_FW_STACK="$stack" \
         -DCNERF_FW_SCENE="${FW_SCENE:-0}" -DCNERF_AMALGAMATED="${FW_AMALGAMATED:-0}" &&
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
fw_md5=$(sed -n 's/^md5 \([0-9a-f]\{32\}\)$/\1/p' "$out")
if [ $rc -ne 0 ] || [ -z "$fw_md5" ]; then
  cat "$out" >&2
  echo "firmware.sh: the firmware failed (exit status $rc)" >&2
  exit 1
fi

# ---- the same tile on the host ----
host=$bdir/render_tile_host
host_src=(decoder/*.c decoder/*.h common/*.h include/cnerf/*.h platform/host/cost_model.[ch]
          tests/xarch/render_tile.c)
if [ ! -x "$host" ] || [ -n "$(find "${host_src[@]}" -newer "$host" 2>/dev/null | head -n 1)" ]; then
  cc -std=c99 -O2 -Wall -Wextra -Werror -Iinclude -Iplatform/host -DCNERF_COST_MODEL \
    decoder/*.c platform/host/cost_model.c tests/xarch/render_tile.c -o "$host"
fi
if ! CNERF_SCENE=${FW_SCENE:-0} CNERF_CORE=$core CNERF_CORE_SET=$set "$host" "$stream" "$camera" $x0 $y0 $w $h \
    $knobs > "$bdir/tile_host.rgb" 2> "$bdir/tile_host.cost"; then
  cat "$bdir/tile_host.cost" >&2
  echo "firmware.sh: the host render failed" >&2
  exit 1
fi
host_md5=$(md5sum < "$bdir/tile_host.rgb" | cut -c1-32)

echo "firmware md5 $fw_md5"
echo "host     md5 $host_md5"
if [ "$fw_md5" != "$host_md5" ]; then
  echo "firmware.sh: MISMATCH: the firmware's tile differs from the host's" >&2
  exit 1
fi
if [ -n "${FW_EXPECT_MD5:-}" ]; then
  echo "expected md5 $FW_EXPECT_MD5"
  if [ "$fw_md5" != "$FW_EXPECT_MD5" ]; then
    echo "firmware.sh: MISMATCH: the tile's MD5 is not the expected FW_EXPECT_MD5" >&2
    exit 1
  fi
fi

# ---- the cost on the target ----
python3 - "$root" "$bdir" "$elf" "$out" "$btype" "$core" "$timer2" <<'PY'
import glob, os, re, shutil, subprocess, sys, tempfile

root, bdir, elf, out, btype, core, timer2 = sys.argv[1:]
sys.path.insert(0, os.path.join(root, "scripts"))
import stack_usage as su  # noqa: E402

fw = {}
for line in open(out):
    f = line.split()
    if len(f) > 2 and f[0] == "fw" and len(f) % 2 == 0:
        fw[f[1]] = {f[i]: int(f[i + 1]) for i in range(2, len(f), 2)}

sec = {}
for line in subprocess.run(["arm-none-eabi-size", "-A", elf], capture_output=True, text=True,
                           check=True).stdout.splitlines():
    f = line.split()
    if len(f) == 3 and f[0].startswith("."):
        sec[f[0]] = int(f[1])
sym = {}
for line in subprocess.run(["arm-none-eabi-nm", "-S", "-t", "d", elf], capture_output=True,
                           text=True, check=True).stdout.splitlines():
    f = line.split()
    if len(f) == 4:
        sym[f[3]] = int(f[1])
n = lambda v: f"{v:,}"

code = sec.get(".vectors", 0) + sec.get(".text", 0) + sec.get(".ARM.exidx", 0)
stream = sym["cnerf_fw_stream"]
consts = sec.get(".rodata", 0) - stream
tables = sum(sym.get(t, 0) for t in ("cn_sin_q30", "cn_exp2_q30", "cn_sigmoid_q30"))
data = sec.get(".data", 0)
flash = code + sec.get(".rodata", 0) + data
bss = sec.get(".bss", 0)
stack_size = sec.get(".stack", 0)
named = {k: sym.get(k, 0) for k in ("ws", "scratch", "dec", "tile")}
print(f"== cost on the target: {core}, {btype}, decoder + firmware, {os.path.basename(elf)} ==")
print(f"flash {n(flash)} bytes: code {n(code)} (vector table {sec.get('.vectors', 0)}), "
      f"constants {n(consts)} (decoder sin/exp2/sigmoid tables {n(tables)}), "
      f"embedded stream {n(stream)}, .data image {n(data)}")
print(f"RAM   {n(data + bss + stack_size)} bytes: .data {n(data)} + .bss {n(bss)} (workspace "
      f"{n(named['ws'])}, render scratch {n(named['scratch'])}, cnerf_decoder {n(named['dec'])}, "
      f"tile buffer {n(named['tile'])}, other {n(bss - sum(named.values()))}) + stack "
      f"{n(stack_size)} reserved")

# Worst-case stack: the decoder's call graph and the firmware's, both from GCC's
# -fcallgraph-info=su, through scripts/stack_usage.py. Its load() reads only directories
# named cnerf_dec.dir, so the firmware's .ci files are staged under that name.
frames, edges, problems = su.load(bdir)
with tempfile.TemporaryDirectory() as tmp:
    stage = os.path.join(tmp, "cnerf_dec.dir")
    os.mkdir(stage)
    for p in glob.glob(os.path.join(bdir, "platform", "cortex-m", "CMakeFiles", "cnerf_fw.dir",
                                    "*.ci")):
        shutil.copy(p, stage)
    f2, e2, p2 = su.load(tmp, check_sources=False)
frames.update(f2)
for k, v in e2.items():
    edges.setdefault(k, set()).update(v)
problems += p2
# Functions GCC's call graphs do not cover (libgcc's integer helpers on Armv6-M): their
# frames and calls from the ELF's disassembly.
missing = {c for k in edges for c in edges[k] if c not in frames}
if missing:
    f3, e3, p3 = su.elf_frames(elf, sorted(missing))
    frames.update(f3)
    for k, v in e3.items():
        edges.setdefault(k, set()).update(v)
    problems += p3
# Fault_Handler is naked assembly that branches to fw_fault_report: an edge GCC cannot see.
edges.setdefault("Fault_Handler", set()).add("fw_fault_report")
# An exception frame + alignment: the basic frame on the M4 (soft float, FPU off); on the M55
# CP10/CP11 are on, and once FP or MVE code has run the frame is the extended one (+ S0-S15,
# FPSCR, VPR).
EXC = (26 * 4 if core == "Cortex-M55" else 32) + 4
try:
    memo = {}
    thread, path = su.deepest("Reset_Handler", frames, edges, [], memo)
    tick, _ = su.deepest("SysTick_Handler", frames, edges, [], memo)
    fault, fpath = su.deepest("Fault_Handler", frames, edges, [], memo)
except (RecursionError, KeyError) as exc:
    problems.append(str(exc))
if problems:
    for p in problems:
        print("firmware.sh: no stack bound:", p, file=sys.stderr)
    sys.exit(1)
worst = thread + EXC + tick + EXC + fault
hw = fw["stack"]["high_water"]
chain = " -> ".join(p.split(":")[-1] for p in path)
print(f"stack worst case {n(worst)} bytes of {n(stack_size)} reserved = thread {thread} "
      f"({chain}) + SysTick {EXC}+{tick} + fault {EXC}+{fault}; measured high-water {hw}")
status = 0
print(f"RAM needed with the stack's worst case instead of the reservation: "
      f"{n(data + bss + worst)} bytes")
if worst > stack_size:
    print(f"firmware.sh: the stack's worst case {worst} exceeds the {stack_size} bytes reserved "
          f"(FW_STACK)", file=sys.stderr)
    status = 1
if hw > thread + EXC + tick:
    print(f"firmware.sh: the measured stack {hw} exceeds the static bound: the call graph is "
          f"incomplete", file=sys.stderr)
    status = 1

# Instructions: 10^9 / (SysTick clock) per SysTick tick under -icount shift=0 (1 ns per
# instruction; 40 at 25 MHz, 31.25 at 32 MHz), valid only if the firmware's calibration loop
# says so (+-1 tick) and the SysTick's wrap counting agrees with the second counter's 32-bit
# count on the same clock over the whole run.
IPT = 1e9 / fw["clock"]["cpu_hz"]
cal, ticks, cross = fw["calib"], fw["ticks"], fw["crosscheck"]
cross2 = next(v for k, v in cross.items() if k != "systick")
ok_cal = abs(cal["ticks"] * IPT - cal["insns"]) <= 2 * IPT
ok_cross = abs(cross["systick"] - cross2) <= 2
r = fw["render"]
rays = r["w"] * r["h"]
print(f"instructions (QEMU -icount shift=0, SysTick ticks x {IPT:g}; each figure +-1 tick): "
      f"calibration loop {n(cal['insns'])} = {n(cal['ticks'])} ticks "
      f"({'ok' if ok_cal else 'FAILED'}), SysTick vs {timer2} over the run "
      f"{n(cross['systick'])} / {n(cross2)} ticks ({'ok' if ok_cross else 'FAILED'})")
if ok_cal and ok_cross:
    ins = {k: round(v * IPT) for k, v in ticks.items()}
    print(f"  cnerf_peek {n(ins['peek'])}, cnerf_open {n(ins['open'])}, md5 of the tile "
          f"{n(ins['md5'])}")
    print(f"  cnerf_render_tile {n(ins['render'])} for {rays} rays ({r['w']}x{r['h']} at "
          f"{r['x0']},{r['y0']}; {r['n_coarse']} coarse + {r['n_fine']} fine samples, t_stop "
          f"{r['t_stop']}): {n(round(ins['render'] / rays))} instructions per ray, per-tile "
          f"set-up included")
    print(f"  work of the tile: rays {rays} evals {r['evals']} in_bounds {r['in_bounds']} "
          f"macs {r['macs']} list_macs {r['list_macs']} list_nz {r['list_nz']} "
          f"samples {r['samples']} layer_values {r['layer_values']} "
          f"exact_rescales {r['exact_rescales']} wide_macs {r['wide_macs']} "
          f"contract {r['contract']} ndc {r['ndc']} in_pos {r['in_pos']} "
          f"samples_per_ray {r['samples_per_ray']} instructions {ins['render']}")
    # The host's count of the same work, with this core's forms (tests/xarch/render_tile.c,
    # cnerf_open_as), must be the firmware's; the cost model's instructions beside QEMU's.
    text = open(os.path.join(bdir, "tile_host.cost")).read()
    hw = re.search(r"host work of the tile: (.*)", text)
    model = re.search(r"cost model [^:]*: (\d+) instructions", text)
    if hw:
        h = dict(zip(hw.group(1).split()[0::2], map(int, hw.group(1).split()[1::2])))
        fwork = dict(r, rays=rays)
        diff = [k for k, v in h.items() if fwork.get(k) != v]
        if diff:
            print(f"firmware.sh: the host's count of the {core}'s work differs from the "
                  f"firmware's in {', '.join(diff)}", file=sys.stderr)
            status = 1
    if model and ins["render"]:
        est = int(model.group(1))
        err = est / ins["render"] - 1
        print(f"  cost model: {n(est)} instructions for the tile, QEMU {n(ins['render'])} "
              f"({100 * err:+.1f}%)")
        tol = os.environ.get("FW_COST_TOLERANCE")
        if tol and abs(err) > float(tol):
            print(f"firmware.sh: the cost model is {100 * err:+.1f}% off, beyond "
                  f"{100 * float(tol):.0f}% (FW_COST_TOLERANCE)", file=sys.stderr)
            status = 1
    grid = f"{r['grid']}^3 grid" if r["grid"] else "no grid"
    use = "ignored (CNERF_RENDER_NO_SKIP)" if r["flags"] & 1 else "used"
    print(f"  network evaluations per ray: {r['evals'] / rays:.2f} ({r['in_bounds'] / rays:.2f} "
          f"samples inside the bounds); {grid}, {use}")
    if r["macs"]:
        print(f"  network multiply-accumulates per ray: {n(round(r['macs'] / rays))}; "
              f"instructions per MAC: {ins['render'] / r['macs']:.2f} (all of "
              f"cnerf_render_tile over the MACs done)")
        print(f"  of them in layers summed from lists of their non-zero latents: "
              f"{n(round(r['list_macs'] / rays))}, which multiplied {n(round(r['list_nz'] / rays))}")
else:
    print("firmware.sh: the instruction counts are not valid (is this QEMU 7.2 with "
          "-icount shift=0?); not reported", file=sys.stderr)
sys.exit(status)
PY
echo "firmware.sh: OK: the firmware's tile has the host's MD5 $fw_md5"
