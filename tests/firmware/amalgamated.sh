#!/usr/bin/env bash
# ctest amalgamated: the single-file decoder of scripts/amalgamate.sh compiles as C99 with the
# decoder's warnings on the host (gcc and clang) and freestanding for the Cortex-M0+, M4 and
# M55; built with tests/xarch/render_tile.c on the host it renders every tile that every
# valid vector lists with the listed MD5; and as Cortex-M4 firmware (FW_AMALGAMATED=1
# scripts/firmware.sh) vector 001's first tile.
#   amalgamated.sh BUILD_DIR
set -euo pipefail
build=$1
root=$(cd "$(dirname "$0")/../.." && pwd)
"$root/scripts/amalgamate.sh" "$build/amal"
warn=(-std=c99 -pedantic -Wall -Wextra -Werror -Wconversion -Wsign-conversion -Wshadow
      -Wcast-qual)
for cc in gcc clang; do
  "$cc" "${warn[@]}" -O2 -c "$build/amal/cnerf_decoder.c" -o "$build/amal/$cc.o"
  echo "compiles with $cc"
done
for cpu in "cortex-m0plus -mfloat-abi=soft" "cortex-m4 -mfloat-abi=soft" "cortex-m55 -mfloat-abi=softfp"; do
  arm-none-eabi-gcc "${warn[@]}" -Os -ffreestanding -mthumb -mcpu=$cpu \
    -c "$build/amal/cnerf_decoder.c" -o "$build/amal/${cpu%% *}.o"
  echo "compiles freestanding for ${cpu%% *}: $(arm-none-eabi-size "$build/amal/${cpu%% *}.o" | awk 'NR == 2 {print $1}') bytes of code"
done
cc -std=c99 -O2 -Wall -Wextra -Werror -I"$build/amal" -I"$root/include" \
  "$root/tests/xarch/render_tile.c" "$build/amal/cnerf_decoder.c" -o "$build/render_tile"
vectors=$root/vectors/valid
tiles=0
for md5 in "$vectors"/*.md5; do
  name=$(basename "$md5" .md5)
  scene=0 stream=$name
  case $name in *.s[0-9]*) scene=${name##*.s} stream=${name%.s*} ;; esac
  while read -r cam x0 y0 w h nc nf ts want; do
    grep -E "[[:space:]]$cam\$" "$vectors/$name.cam" > "$build/cam.txt"
    got=$(CNERF_SCENE=$scene "$build/render_tile" "$vectors/$stream.cnrf" "$build/cam.txt" \
          "$x0" "$y0" "$w" "$h" "$nc" "$nf" "$ts" | md5sum | cut -c1-32)
    [ "$got" = "$want" ] || { echo "FAIL: $name $cam $x0 $y0 $w $h: $got, listed $want"; exit 1; }
    tiles=$((tiles + 1))
  done < "$md5"
done
# and their tiles in RGB565 (valid/RGB565)
while read -r name cam x0 y0 w h nc nf ts flags want; do
  scene=0 stream=$name
  case $name in *.s[0-9]*) scene=${name##*.s} stream=${name%.s*} ;; esac
  grep -E "[[:space:]]$cam\$" "$vectors/$name.cam" > "$build/cam.txt"
  got=$(CNERF_SCENE=$scene "$build/render_tile" "$vectors/$stream.cnrf" "$build/cam.txt" \
        "$x0" "$y0" "$w" "$h" "$nc" "$nf" "$ts" "$flags" | md5sum | cut -c1-32)
  [ "$got" = "$want" ] || { echo "FAIL: $name $cam RGB565 flags $flags: $got, listed $want"; exit 1; }
  tiles=$((tiles + 1))
done < "$vectors/RGB565"
echo "host: $tiles tiles of the valid vectors (RGB888 and RGB565), each with its listed MD5"
v=$vectors/001-lego-encode-tiny
read -r cam x0 y0 w h nc nf ts want < <(head -n 1 "$v.md5")
grep -E "[[:space:]]$cam\$" "$v.cam" > "$build/cam.txt"
FW_AMALGAMATED=1 FW_BUILD_DIR=$build/fw FW_EXPECT_MD5=$want "$root/scripts/firmware.sh" \
  "$v.cnrf" "$build/cam.txt" "$x0 $y0 $w $h" "$nc" "$nf" "$ts" | tail -n 1
