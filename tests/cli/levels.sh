#!/usr/bin/env bash
# Levels end to end (docs/bitstream.md, levl): cnerf recode declares them on the README main
# job's reference stream and codes its grid by blocks, with the same pixels (and back, to the
# same bytes); a decoder built
# with CNERF_MAX_LEVEL=1 and static arenas of level 1 (tests/level/max_level.c) opens and
# renders the level-1 stream as the library decoder does, and refuses the others with
# CNERF_E_LEVEL; a level the stream cannot meet is refused by recode with what exceeds it.
#   levels.sh CNERF CONFORM MAX_LEVEL_1 MAX_LEVEL_REF SOURCE_DIR OUT_DIR
set -euo pipefail
cnerf=$1 conform=$2 l1=$3 ref=$4 src=$5 out=$6
rm -rf "$out"
mkdir -p "$out"
s=$src/experiments/data/lego-c070829.cnrf
cams=$src/experiments/data/lego-c070829.r_0.cam
fail() { echo "FAIL: $*" >&2; exit 1; }

"$cnerf" recode "$s" -o "$out/l1.cnrf" --level 1 > /dev/null
"$cnerf" recode "$s" -o "$out/l2.cnrf" --level 2 > /dev/null
"$cnerf" recode "$s" -o "$out/none.cnrf" > /dev/null
"$cnerf" info --no-estimate "$out/l1.cnrf" > "$out/info1"
grep -q '^level: 1 (declared)' "$out/info1" || fail "info: no level 1"
"$cnerf" info --no-estimate "$out/none.cnrf" > "$out/info0"
grep -q '^level: none declared; the scene fits level 1' "$out/info0" || fail "info: the lowest level"
# the same pixels: every 16x16 tile of view r_0, from the original and the re-coded
want=$("$conform" tiles "$s" "$cams" 16 32 32 262144 | md5sum)
for f in l1 l2 none; do
  got=$("$conform" tiles "$out/$f.cnrf" "$cams" 16 32 32 262144 | md5sum)
  [ "$got" = "$want" ] || fail "$f.cnrf renders other pixels than the stream it re-codes"
done
# and back: cell by cell, no level, the original stream byte for byte (what a 2.2 decoder reads)
"$cnerf" recode "$out/l1.cnrf" -o "$out/back.cnrf" --grid-coding cells --no-level > /dev/null
cmp "$out/back.cnrf" "$s" || fail "recoding back gives other bytes than the original"
# the level-1 decoder: static arenas of level 1, the same pixels as the library's
"$l1" "$out/l1.cnrf" 0 "$out/l1.rgb"
"$ref" "$out/l1.cnrf" 0 "$out/ref.rgb"
cmp "$out/l1.rgb" "$out/ref.rgb" || fail "the level-1 decoder renders other pixels"
"$l1" "$out/l2.cnrf" -27           # CNERF_E_LEVEL: above the decoder's level
"$l1" "$out/none.cnrf" -27         # and a stream that declares none
"$l1" "$s" -27
"$ref" "$out/l2.cnrf" 0             # a decoder of any level takes them all
"$ref" "$s" 0
# a level the stream cannot meet: refused, nothing written, what exceeds it said
"$cnerf" synth -o "$out/small.cnrf" --preset small > /dev/null
if "$cnerf" recode "$out/small.cnrf" -o "$out/small-l1.cnrf" --level 1 2> "$out/err"; then
  fail "recode accepted a level the stream exceeds"
fi
grep -q 'does not fit level 1: workspace 189376 bytes > 73728' "$out/err" || fail "$(cat "$out/err")"
[ ! -e "$out/small-l1.cnrf" ] || fail "recode wrote a stream that does not fit"
"$cnerf" recode "$out/small.cnrf" -o "$out/small-l3.cnrf" --level 3 > /dev/null
echo "levels: ok"
