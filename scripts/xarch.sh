#!/usr/bin/env bash
# Bit-exactness across architectures: builds tests/xarch/render_tile.c (and the look-at
# vectors' tool, vectors/tools/lookat.c) with the decoder for the host and, with Debian's
# cross compilers, for aarch64, armhf and s390x (big-endian), and with clang and wasi-libc
# for WebAssembly (wasm32-wasi), runs the foreign builds under qemu-user and the wasm32 one
# under Node (platform/web/wasi_run.mjs), and checks that every tile's MD5 is the same
# everywhere. Streams: synthetic 360-degree and NDC models from `cnerf synth` (built in
# build/ by scripts/test.sh), two of them with occupancy grids, one with narrower layers, and the demo stream
# out/lego.cnrf when it exists; and the first tile of every conformance vector, which must
# also have the MD5 the vector lists. Last, each little-endian architecture renders vector
# 034's tiles from its packed image for the kernels it chose (vectors/packed/), and each
# architecture whose kernels' int8 sums cost more renders every vector's first tile again with
# the fast workspace (cnerf_workspace_size_fast).
#   scripts/xarch.sh [--size PX]
# (PX: the synthetic streams' image, 24 by default, even; its four quarters are the tiles. Their
# rays under qemu-user are most of the script's time: at 32 the aarch64 build took 1.9 times
# the CPU time on them, 191 s against 102.)
set -euo pipefail
cd "$(dirname "$0")/.."
size=24
[ "${1:-}" = "--size" ] && size=$2
cnerf=build/cnerf
[ -x $cnerf ] || { echo "xarch.sh: build first (scripts/test.sh)" >&2; exit 1; }
work=$PWD/build-xarch # absolute: the wasm32 programs see the host's files from /
rm -rf "$work"
mkdir -p "$work"
dec=(decoder/*.c) # the portable C and every instruction set's kernels
flags=(-std=c99 -O2 -Wall -Wextra -Werror -Iinclude)

# target: name compiler runner
targets=("x86-64 gcc -")
# WebAssembly: clang for wasm32-wasi with 128-bit SIMD (the simd128 kernels), Debian's
# wasi-libc and compiler-rt, run by Node
wasm32-wasi-cc() { clang --target=wasm32-wasi -msimd128 "$@"; }
node-wasi() { node "$PWD/platform/web/wasi_run.mjs" "$@"; }
# on RUN CMD...: CMD on the host (RUN "-") or under RUN (qemu-user, node-wasi)
on() {
  local run=$1
  shift
  if [ "$run" = "-" ]; then "$@"; else "$run" "$@"; fi
}
for t in "aarch64 aarch64-linux-gnu-gcc qemu-aarch64" "armhf arm-linux-gnueabihf-gcc qemu-arm" \
         "s390x s390x-linux-gnu-gcc qemu-s390x" "wasm32 wasm32-wasi-cc node-wasi"; do
  read -r name cc run <<< "$t"
  if [ "$name" = wasm32 ]; then
    if ! command -v clang > /dev/null || ! command -v node > /dev/null || ! command -v wasm-ld > /dev/null ||
       [ ! -f /usr/lib/wasm32-wasi/libc.a ]; then
      echo "xarch.sh: clang, wasm-ld, node or wasi-libc is missing (apt-get install clang lld nodejs wasi-libc libclang-rt-14-dev-wasm32)" >&2
      exit 1
    fi
  elif ! command -v "$cc" > /dev/null || ! command -v "$run" > /dev/null; then
    echo "xarch.sh: $cc or $run is missing (apt-get install gcc-${name/armhf/arm-linux-gnueabihf} qemu-user)" >&2
    exit 1
  fi
  targets+=("$t")
done
jobs_max=$(nproc 2>/dev/null || echo 2)
# (the targets' builds side by side, one a core: each compiles the whole decoder three times)
build_for() { # NAME CC RUN
  local name=$1 cc=$2 run=$3 static
  static=$([ "$run" = "-" ] || [ "$name" = wasm32 ] && echo "" || echo "-static")
  $cc "${flags[@]}" $static "${dec[@]}" tests/xarch/render_tile.c -o "$work/render_tile.$name" &&
  $cc "${flags[@]}" $static "${dec[@]}" tests/xarch/check_kernels.c -o "$work/check_kernels.$name" &&
  $cc "${flags[@]}" $static "${dec[@]}" vectors/tools/lookat.c -o "$work/lookat.$name" &&
  echo "built for $name with $cc"
}
pids=()
for t in "${targets[@]}"; do
  read -r name cc run <<< "$t"
  build_for "$name" "$cc" "$run" &
  pids+=($!)
  while [ "$(jobs -rp | wc -l)" -ge "$jobs_max" ]; do sleep 0.2; done
done
for p in "${pids[@]}"; do wait "$p" || { echo "xarch.sh: a build failed" >&2; exit 1; }; done
# The look-at cameras of the vectors (valid/LOOKAT), made on each architecture.
for t in "${targets[@]}"; do
  read -r name cc run <<< "$t"
  on "$run" "$work/lookat.$name" > "$work/lookat.$name.txt"
  cmp -s "$work/lookat.$name.txt" vectors/valid/LOOKAT ||
    { echo "xarch.sh: $name's look-at cameras differ from vectors/valid/LOOKAT" >&2; exit 1; }
  echo "$name: the $(wc -l < vectors/valid/LOOKAT) look-at cases of vectors/valid/LOOKAT, line for line"
done
# Each architecture's kernels against its portable C (tests/xarch/check_kernels.c).
for t in "${targets[@]}"; do
  read -r name cc run <<< "$t"
  out=$(on "$run" "$work/check_kernels.$name" 1)
  echo "$name: $(head -n 1 <<< "$out"); $(tail -n 1 <<< "$out")"
  sed -n '1s/.*(chosen: \([a-z0-9]*\)).*/\1/p' <<< "$out" > "$work/set.$name"
  # (1 when the fast workspace changes the kernels' sums: int16 where int8 cost more)
  sed -n '1{s/.*whose int8 sums cost more$/1/p;t;s/.*/0/p}' <<< "$out" > "$work/fast.$name"
  tail -n 1 <<< "$out" | grep -q " 0 failed$" || { echo "$out" >&2; exit 1; }
done

# Streams and cameras.
$cnerf synth -o "$work/tiny.cnrf" --preset tiny --seed 3 > /dev/null
$cnerf synth -o "$work/small.cnrf" --preset small --seed 4 > /dev/null
$cnerf synth -o "$work/ndc.cnrf" --preset tiny --seed 5 --ndc --black > /dev/null
# occupancy grids: a ball of occupied cells in the fog, and a 5^3 grid in NDC space
$cnerf synth -o "$work/grid.cnrf" --preset tiny --seed 6 --grid 16 > /dev/null
$cnerf synth -o "$work/gridndc.cnrf" --preset tiny --seed 7 --ndc --grid 5 > /dev/null
# layers narrower than the width (format 1.2, a UNIT chunk), into the skip and the view branch
$cnerf synth -o "$work/units.cnrf" --preset tiny --seed 8 --units 20,7,32,64:5 > /dev/null
# two scenes sharing shifts (format 2.1): scene 1 is rendered (CNERF_SCENE), shifts included
$cnerf synth -o "$work/scenes.cnrf" --preset tiny --seed 9 --scenes 2 > /dev/null
# a contracted scene (format 2.2): all space beyond the inner cube drawn into the bounds
$cnerf synth -o "$work/contract.cnrf" --preset tiny --seed 10 --contract > /dev/null
streams=("$work/tiny.cnrf" "$work/small.cnrf" "$work/ndc.cnrf" "$work/grid.cnrf" "$work/gridndc.cnrf"
         "$work/units.cnrf" "$work/scenes.cnrf" "$work/contract.cnrf")
[ -f out/lego.cnrf ] && streams+=("$PWD/out/lego.cnrf")
half=$((size / 2))
f=$(( size * 65536 * 3 / 2 ))  # focal length 1.5 image widths: about 37 degrees
c=$(( half * 65536 ))
Q30=1073741824 Q32=4294967296
# looking down -z from z = 4; from -y towards +y; an oblique view (rotation by python3).
echo "$Q30 0 0  0 $Q30 0  0 0 $Q30  0 0 $((4 * Q32))  $f $f $c $c $size $size" > "$work/cam_z"
echo "$Q30 0 0  0 0 -$Q30  0 $Q30 0  0 $((-4 * Q32)) 0  $f $f $c $c $size $size" > "$work/cam_y"
python3 - "$size" "$f" "$c" > "$work/cam_oblique" <<'PY'
import math, sys
size, f, c = (int(v) for v in sys.argv[1:])
p = [2.6, -2.2, 1.9]
n = math.sqrt(sum(v * v for v in p)); back = [v / n for v in p]
right = [-back[1], back[0], 0.0]; rn = math.hypot(right[0], right[1]); right = [v / rn for v in right]
up = [back[1] * right[2] - back[2] * right[1], back[2] * right[0] - back[0] * right[2],
      back[0] * right[1] - back[1] * right[0]]
rot = [round(m * 2 ** 30) for row in zip(right, up, back) for m in row]
print(*rot, *(round(v * 2 ** 32) for v in p), f, f, c, c, size, size)
PY

# The tiles: stream, scene, camera, tile and knobs, one a line; each architecture renders them
# all (in parallel, one architecture a core), then their MD5s are compared line by line.
: > "$work/tiles"
for s in "${streams[@]}"; do
  # the stream of several scenes: its scene 1
  scene=$([ "$(basename "$s")" = scenes.cnrf ] && echo 1 || echo 0)
  for cam in cam_z cam_y cam_oblique; do
    for tile in "0 0 $half $half" "$half 0 $half $half" "0 $half $half $half" "$half $half $half $half" "3 5 1 1"; do
      knobs_list=("" "8 4 0")
      # RGB565 in both byte orders (CNERF_RENDER_RGB565, _BE) on the first stream
      [ "$s" = "${streams[0]}" ] && knobs_list+=("8 4 0 4" "8 4 0 8")
      for knobs in "${knobs_list[@]}"; do
        echo "$s|$scene|$cam|$tile|$knobs" >> "$work/tiles"
      done
    done
  done
done
# The conformance vectors' first tiles (the first line of each valid/NAME.md5, and of each
# NAME.s<m>.md5 for scene m), which every architecture must render with the vector's MD5.
: > "$work/vector_md5"
for md5f in vectors/valid/*.md5; do
  base=$(basename "$md5f" .md5) # NAME, or NAME.s<m>
  scene=0
  [[ $base == *.s* ]] && scene=${base##*.s}
  read -r cname x0 y0 w h nc nf ts want < "$md5f"
  grep -E "[[:space:]]$cname\$" "vectors/valid/$base.cam" > "$work/vcam.$base"
  echo "$PWD/vectors/valid/${base%%.*}.cnrf|$scene|vcam.$base|$x0 $y0 $w $h|$nc $nf $ts" >> "$work/tiles"
  echo "$(wc -l < "$work/tiles") $want $base" >> "$work/vector_md5"
done

# Every tile of a list in one process (render_tile --jobs: under qemu-user and Node, starting a
# process costs more than most tiles), one file each, then their MD5s a line each.
render_list() { # NAME RUN LIST OUT: the MD5s of LIST's tiles into OUT
  local name=$1 run=$2 list=$3 out=$4 dir=$4.d
  rm -rf "$dir" && mkdir -p "$dir"
  on "$run" "$work/render_tile.$name" --jobs "$list" "$dir" ||
    echo "xarch.sh: $name: render_tile --jobs $list failed" >&2
  local i n
  n=$(wc -l < "$list")
  for ((i = 1; i <= n; i++)); do
    [ -f "$dir/$i.rgb" ] || break
    md5sum < "$dir/$i.rgb" | cut -c1-32
  done > "$out"
  rm -rf "$dir"
}
# the tiles with each camera's path: render_tile --jobs's list
while IFS='|' read -r s scene cam tile knobs; do
  echo "$s|$scene|$work/$cam|$tile|$knobs"
done < "$work/tiles" > "$work/jobs"
render_all() { # NAME RUN: every tile's MD5, a line each, into $work/md5.NAME
  render_list "$1" "$2" "$work/jobs" "$work/md5.$1"
}
pids=()
for t in "${targets[@]}"; do
  read -r name cc run <<< "$t"
  render_all "$name" "$run" &
  pids+=($!)
  while [ "$(jobs -rp | wc -l)" -ge "$jobs_max" ]; do sleep 0.2; done
done
for p in "${pids[@]}"; do wait "$p"; done
bad=0 n=0
while IFS='|' read -r s scene cam tile knobs; do
  n=$((n + 1))
  ref="" line=""
  for t in "${targets[@]}"; do
    read -r name cc run <<< "$t"
    md5=$(sed -n "${n}p" "$work/md5.$name")
    [ -n "$md5" ] || { echo "xarch.sh: $name rendered no tile $n" >&2; exit 1; }
    [ -z "$ref" ] && ref=$md5
    line+=" $name=${md5:0:8}"
    [ "$md5" = "$ref" ] || bad=1
  done
  echo "$(basename "$s") $cam [$tile] ${knobs:-defaults}:$line"
done < "$work/tiles"
if [ $bad -ne 0 ]; then
  echo "xarch.sh: MD5s differ between architectures" >&2
  exit 1
fi
while read -r line want base; do
  got=$(sed -n "${line}p" "$work/md5.x86-64")
  [ "$got" = "$want" ] || { echo "xarch.sh: vector $base's first tile: $got, the vector lists $want" >&2; bad=1; }
done < "$work/vector_md5"
if [ $bad -ne 0 ]; then
  echo "xarch.sh: a vector's tile differs from its MD5" >&2
  exit 1
fi
# Vector 034 packed for the kernels each little-endian architecture chose (vectors/packed/,
# read in place by cnerf_open_packed): every tile of the vector, with its MD5s.
packed=0
v=034-level-1-small
for t in "${targets[@]}"; do
  read -r name cc run <<< "$t"
  set=$(cat "$work/set.$name")
  img=$PWD/vectors/packed/$v.$set.img
  [ "$name" != s390x ] && [ -f "$img" ] || continue # images are little-endian
  while read -r cname x0 y0 w h nc nf ts want; do
    grep -E "[[:space:]]$cname\$" "vectors/valid/$v.cam" > "$work/pcam"
    got=$(on "$run" "$work/render_tile.$name" "$img" "$work/pcam" $x0 $y0 $w $h $nc $nf $ts |
          md5sum | cut -c1-32)
    [ "$got" = "$want" ] || { echo "xarch.sh: $name: $v.$set.img, tile $cname $x0 $y0: $got, the vector lists $want" >&2; exit 1; }
    packed=$((packed + 1))
  done < "vectors/valid/$v.md5"
  echo "$name: vector $v's $(wc -l < "vectors/valid/$v.md5") tiles from its image for $set (packed/), with the vector's MD5s"
done
# Every vector's first tile again with a workspace of cnerf_workspace_size_fast bytes (every
# latent as int16 where the kernels' int8 sums cost more: aarch64's and armhf's; on the other
# architectures that workspace changes nothing): the MD5s the vectors list. An architecture
# a job, as render_all.
render_fast() { # NAME RUN: each vector's first tile, "MD5 WANT BASE" a line, into $work/fast_md5.NAME
  local name=$1 run=$2
  CNERF_WS_FAST=1 render_list "$name" "$run" "$work/fast_jobs" "$work/fast_only.$name"
  paste -d ' ' "$work/fast_only.$name" <(cut -d ' ' -f 2,3 "$work/vector_md5" |
    head -n "$(wc -l < "$work/fast_only.$name")") > "$work/fast_md5.$name"
}
while read -r line want base; do sed -n "${line}p" "$work/jobs"; done < "$work/vector_md5" \
  > "$work/fast_jobs"
fast=0 fast_on=() pids=()
for t in "${targets[@]}"; do
  read -r name cc run <<< "$t"
  [ "$(cat "$work/fast.$name")" = 1 ] || continue
  fast_on+=("$name")
  render_fast "$name" "$run" &
  pids+=($!)
  while [ "$(jobs -rp | wc -l)" -ge "$jobs_max" ]; do sleep 0.2; done
done
for p in "${pids[@]}"; do wait "$p"; done
for name in "${fast_on[@]}"; do
  [ "$(wc -l < "$work/fast_md5.$name")" = "$(wc -l < "$work/vector_md5")" ] ||
    { echo "xarch.sh: $name: not every vector's tile rendered with the fast workspace" >&2; exit 1; }
  while read -r got want base; do
    [ "$got" = "$want" ] || { echo "xarch.sh: $name: vector $base's first tile with the fast workspace: $got, the vector lists $want" >&2; exit 1; }
    fast=$((fast + 1))
  done < "$work/fast_md5.$name"
done
fast_on=${fast_on[*]}
echo "xarch.sh: $n tiles, the same MD5 on ${#targets[@]} architectures, $(wc -l < "$work/vector_md5") of them the conformance vectors' first tiles with the MD5s they list; $packed tiles from packed images; $fast with the fast workspace (${fast_on:-no architecture whose int8 sums cost more})"
