#!/usr/bin/env bash
# Writes vectors/valid/RGB565: the first tile of every valid vector (every scene of a
# stream of several) in RGB565, both byte orders (CNERF_RENDER_RGB565, _RGB565_BE; the rule in
# docs/rendering.md, Output), rendered by this tree's decoder (tests/xarch/render_tile.c).
# One line a tile: NAME CAMERA X0 Y0 W H N_COARSE N_FINE T_STOP FLAGS MD5, the MD5 over the
# tile's rows of w * 2 bytes. Then MANIFEST.sha256 again. vectors/regenerate.sh runs it; run
# it alone when only the output rule changed (the streams are as they were).
set -euo pipefail
cd "$(dirname "$0")/.."
tool=$(mktemp -d)
trap 'rm -rf "$tool"' EXIT
cc -std=c99 -O2 -Wall -Wextra -Werror -Iinclude decoder/*.c tests/xarch/render_tile.c -o "$tool/render_tile"
out=vectors/valid/RGB565
: > "$out.new"
for md5 in vectors/valid/*.md5; do
  name=$(basename "$md5" .md5)
  scene=0 stream=$name
  case $name in *.s[0-9]*) scene=${name##*.s} stream=${name%.s*} ;; esac
  read -r cam x0 y0 w h nc nf ts _ < <(head -n 1 "$md5")
  grep -E "[[:space:]]$cam\$" "vectors/valid/$name.cam" > "$tool/cam"
  for flags in 4 8; do
    sum=$(CNERF_SCENE=$scene "$tool/render_tile" "vectors/valid/$stream.cnrf" "$tool/cam" \
            "$x0" "$y0" "$w" "$h" "$nc" "$nf" "$ts" "$flags" | md5sum | cut -c1-32)
    echo "$name $cam $x0 $y0 $w $h $nc $nf $ts $flags $sum" >> "$out.new"
  done
done
mv "$out.new" "$out"
(cd vectors && find valid invalid $([ -d packed ] && echo packed) -type f | LC_ALL=C sort | xargs sha256sum > MANIFEST.sha256)
echo "vectors/rgb565.sh: $(wc -l < "$out") RGB565 tiles in $out" >&2
