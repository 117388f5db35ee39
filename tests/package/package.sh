#!/usr/bin/env bash
# ctest package: the decoder installed as a package (cmake --install) and used by an outside
# project, as a user would: examples/host built with find_package(cnerf) and again with
# pkg-config, and its row-by-row render of vector 001's first tile must have the MD5 the
# vector lists.
#   package.sh BUILD_DIR
set -euo pipefail
build=$1
root=$(cd "$(dirname "$0")/../.." && pwd)
rm -rf "$build"
cmake -S "$root" -B "$build/tree" -DCNERF_BUILD_ENCODER=OFF -DCNERF_BUILD_TESTS=OFF \
  -DCMAKE_BUILD_TYPE=Release > /dev/null
cmake --build "$build/tree" -j2 > /dev/null
cmake --install "$build/tree" --prefix "$build/prefix" > /dev/null
echo "installed: $(cd "$build/prefix" && find . -type f | sort | tr '\n' ' ')"
cmake -S "$root/examples/host" -B "$build/example" -DCMAKE_PREFIX_PATH="$build/prefix" > /dev/null
cmake --build "$build/example" > /dev/null
echo "examples/host builds with find_package(cnerf)"
PKG_CONFIG_PATH=$build/prefix/lib/pkgconfig
export PKG_CONFIG_PATH
cc -std=c99 -Wall -Wextra -Werror "$root/examples/host/render_rows.c" \
  $(pkg-config --cflags --libs cnerf) -o "$build/render_rows_pc"
echo "examples/host builds with pkg-config cnerf ($(pkg-config --modversion cnerf))"
v=$root/vectors/valid/001-lego-encode-tiny
read -r cam x0 y0 w h nc nf ts md5 < <(head -n 1 "$v.md5")
grep -E "[[:space:]]$cam\$" "$v.cam" > "$build/cam.txt"
for bin in "$build/example/render_rows" "$build/render_rows_pc"; do
  "$bin" "$v.cnrf" "$build/cam.txt" "$build/tile.ppm" "$x0" "$y0" "$w" "$h" "$nc" "$nf" "$ts"
  got=$(tail -c $((w * h * 3)) "$build/tile.ppm" | md5sum | cut -c1-32)
  [ "$got" = "$md5" ] || { echo "FAIL: $bin rendered $got, the vector lists $md5"; exit 1; }
  echo "$(basename "$bin"): vector 001's tile row by row, $got as listed"
done
