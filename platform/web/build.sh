#!/bin/sh
# Builds the decoder as a WebAssembly module with no imports, and the JavaScript package's
# one-file bundle for pages that cannot load modules (a page opened from file://):
#   platform/web/build.sh OUTDIR
# writes OUTDIR/cnerf.wasm (clang for wasm32 with 128-bit SIMD, freestanding, linked by
# wasm-ld with no entry point; the decoder's sources and platform/web/cnerf_web.c) and
# OUTDIR/cnerf-bundle.js (core.js, index.js and viewer.js as one classic script: their imports
# dropped, their exports plain declarations, import.meta.url the page's address).
# Needs clang and wasm-ld (Debian: apt-get install clang lld).
set -eu
out=${1:?usage: platform/web/build.sh OUTDIR}
root=$(cd "$(dirname "$0")/../.." && pwd)
cc=${CLANG:-clang}
ld=${WASM_LD:-wasm-ld}
for t in "$cc" "$ld"; do
  command -v "$t" > /dev/null || {
    echo "platform/web/build.sh: $t is missing (apt-get install clang lld)" >&2
    exit 1
  }
done
mkdir -p "$out/obj"
for f in "$root"/decoder/*.c "$root"/platform/web/cnerf_web.c; do
  "$cc" --target=wasm32 -msimd128 -O2 -std=c99 -ffreestanding -nostdlib -Wall -Wextra -Werror \
    -I"$root/include" -c "$f" -o "$out/obj/$(basename "$f" .c).o"
done
# 256 KiB of stack: the renderer's frames are bounded (docs/decoder.md) and far smaller
"$ld" --no-entry --export=__heap_base -z stack-size=262144 --strip-all "$out"/obj/*.o \
  -o "$out/cnerf.wasm.tmp"
mv "$out/cnerf.wasm.tmp" "$out/cnerf.wasm"

js=$root/platform/web/js
{
  echo "// cnerf's viewer and package as one classic script (platform/web/build.sh)."
  echo "'use strict';"
  for f in core.js index.js viewer.js; do
    sed -e '/^import .* from .*;$/d' -e '/^export {.*};$/d' \
        -e 's/^export \(async function\|function\|class\|const\)/\1/' \
        -e 's/import\.meta\.url/location.href/g' "$js/$f"
  done
} > "$out/cnerf-bundle.js.tmp"
mv "$out/cnerf-bundle.js.tmp" "$out/cnerf-bundle.js"

# The page as a site: OUTDIR/index.html, OUTDIR/js/ and OUTDIR/cnerf.wasm (module scripts need
# a server: python3 -m http.server -d OUTDIR). OUTDIR/js is also the npm package: its module,
# types, package.json and cnerf.wasm (npm pack OUTDIR/js).
mkdir -p "$out/js"
cp "$root/platform/web/index.html" "$out/index.html"
cp "$js"/*.js "$js"/*.d.ts "$js/package.json" "$out/cnerf.wasm" "$out/js/"
