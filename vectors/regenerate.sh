#!/usr/bin/env bash
# Regenerates every conformance vector in vectors/ (docs/conformance.md), seeded, and stamps
# each valid vector's provenance into NAME.txt.
#   vectors/regenerate.sh      (builds and uses build/ or $CNERF_BUILD; scenes from ../shared/data)
# Real-scene streams come from training: another CPU or BLAS build may give other (equally
# valid) streams, so the committed vectors, checked by MANIFEST.sha256, are the reference.
set -euo pipefail
cd "$(dirname "$0")/.."
data=${CNERF_DATA:-../shared/data}
seed=20261123
build=${CNERF_BUILD:-build}
cmake -S . -B $build -DCMAKE_BUILD_TYPE=RelWithDebInfo > /dev/null
cmake --build $build -j"$(nproc)" --target cnerf conform make_invalid > /dev/null
cnerf=$build/cnerf conform=$build/tests/conform
version=$($cnerf --version)
rev=$(git rev-parse --short HEAD 2> /dev/null || echo unknown)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
rm -rf vectors/valid vectors/invalid vectors/packed
mkdir -p vectors/valid vectors/invalid
: > vectors/valid/LIST

# Cameras and float reference renders of stream $1 into vectors/valid/$2.*, from the
# cnerf render options in $3 (a dataset's test views or an orbit).
cams_and_refs() {
  local stream=$1 name=$2 opts=$3
  rm -rf "$tmp/ref"
  # shellcheck disable=SC2086
  $cnerf render "$stream" $opts --float -o "$tmp/ref" --save-cameras "vectors/valid/$name.cam" \
    > /dev/null
  for png in "$tmp"/ref/*.png; do
    cp "$png" "vectors/valid/$name.$(basename "$png" .png).ref.png"
  done
  # shellcheck disable=SC2086
  $cnerf render "$stream" $opts > "$tmp/fixed.log"
}

# vector NAME FEATURE COMMAND... : runs COMMAND (which writes $tmp/s.cnrf), then the
# cameras in $CAMS, the tile MD5s (16x16 tiles, the stream's knobs on every camera and halved
# sample counts with early termination at 1/1024 on the first) and NAME.txt. A stream of
# several scenes gets the same for each scene listed in $SCENES (scene 0 always) into
# NAME.s<m>.* for scene m > 0.
vector() {
  local name=$1 feature=$2
  shift 2
  echo "== $name: $feature" >&2
  rm -f "$tmp/s.cnrf" "$tmp/s.cnrf.ckpt"
  "$@" > "$tmp/cmd.log"
  cp "$tmp/s.cnrf" "vectors/valid/$name.cnrf"
  local m sfx vs min worst=inf tiles=0 hc hf nc nf
  for m in 0 ${SCENES:-}; do
    sfx=$([ "$m" = 0 ] && echo "" || echo ".s$m")
    cams_and_refs "vectors/valid/$name.cnrf" "$name$sfx" "$CAMS --scene $m"
    read -r nc nf < <($cnerf info --scene "$m" "vectors/valid/$name.cnrf" |
      sed -n 's/^samples: \([0-9]*\) coarse + \([0-9]*\) fine$/\1 \2/p')
    $conform tiles "vectors/valid/$name.cnrf" "vectors/valid/$name$sfx.cam" 16 "$nc" "$nf" 262144 \
      "$m" > "vectors/valid/$name$sfx.md5"
    head -n 1 "vectors/valid/$name$sfx.cam" > "$tmp/cam1"
    hc=$(((nc + 1) / 2)) hf=$((nf / 2))
    $conform tiles "vectors/valid/$name.cnrf" "$tmp/cam1" 16 "$hc" "$hf" 1048576 "$m" \
      >> "vectors/valid/$name$sfx.md5"
    tiles=$((tiles + $(wc -l < "vectors/valid/$name$sfx.md5")))
    vs=$(sed -n 's/^mean over .* vs float \([0-9.]*\) dB.*/\1/p; s/^mean over .* vs float: identical.*/inf/p' "$tmp/fixed.log")
    worst=$(python3 -c "print(min(float('$vs'), float('$worst')))")
  done
  # A port that is not bit-exact must come within 40 dB of the float reference, or, for
  # streams that saturate the fixed-point range on purpose, 3 dB of what this decoder reaches.
  min=$(python3 -c "v=float('$worst'); print(40 if v >= 43 else max(0, int(v) - 3))")
  {
    echo "feature: $feature"
    echo "encoder: $version, commit $rev"
    echo "command: $(printf '%s ' "$@" | sed "s|$tmp/s.cnrf|$name.cnrf|g; s|$tmp/|(make_invalid)/|g; s/ $//")"
    echo "seed: $seed"
    [ -z "${SCENES:-}" ] || echo "scenes checked: 0 ${SCENES} (files NAME.s<m>.* for scene m > 0)"
    echo "cameras: $(awk '{print $19 " (" $17 "x" $18 ")"}' "vectors/valid/$name.cam" | paste -sd, - | sed 's/,/, /g')"
    echo "tiles: $tiles MD5s (16x16 tiles; the stream's knobs on every camera, $hc+$hf samples and t_stop 2^20 on the first)"
    echo "fixed point against the float reference: $(sed 's/^inf$/inf/' <<< "$worst") dB (mean over the cameras, this decoder$([ -z "${SCENES:-}" ] || echo ", the worst scene"))"
    echo "min_psnr: $min"
    echo "level: $($cnerf info "vectors/valid/$name.cnrf" | sed -n 's/^level: \([0-9]*\) (declared).*/\1/p; s/^level: none.*/none/p')"
  } > "vectors/valid/$name.txt"
  echo "$name" >> vectors/valid/LIST
}

# Real scenes through the encoder (few iterations: these test the decoder, not the encoder;
# the grid's needs a model sharp enough for its grid to have empty cells).
CAMS="--dataset $data/lego --downscale 8 --every 100"
vector 001-lego-encode-tiny "a real 360-degree scene from cnerf encode (Blender Lego, 50x50; no grid)" \
  $cnerf encode "$data/lego" -o "$tmp/s.cnrf" --lambda 1e-3 --preset tiny --downscale 8 \
  --iters 200 --seed $seed --threads 2 --every 100 --grid 0 --prune off --coarse-color on
CAMS="--dataset $data/fern --downscale 8 --every 2"
vector 002-fern-encode-tiny-ndc "a real forward-facing scene in NDC from cnerf encode (LLFF Fern, 63x47; no grid)" \
  $cnerf encode "$data/fern" -o "$tmp/s.cnrf" --lambda 1e-3 --preset tiny --downscale 8 \
  --iters 200 --seed $seed --threads 2 --every 100 --grid 0 --prune off --coarse-color on

# Features of the format, on random models (cnerf synth).
CAMS="--orbit 2 --size 24"
vector 003-int16-latents "latents beyond the int8 range (magnitudes in the hundreds): int16 latents, int32 sums" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --spread 300
vector 004-black-background "a black background" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --black
vector 005-one-sample "one coarse sample and no fine network" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --coarse 1 --fine 0
vector 006-empty-range-layers "every layer's latents in an empty range (kmin = kmax, no payload)" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --spread 0
vector 007-no-view-branch "networks without a view-direction branch" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --view-width 0
vector 008-small-preset "4x128 networks with a view branch of 64, 32+32 samples" \
  $cnerf synth -o "$tmp/s.cnrf" --preset small --view-width 64 --seed $seed
CAMS="--orbit 1 --size 8"
vector 009-largest-limits "the largest depth, octaves and sample counts, and latents near +-32767 (sums in int64)" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --depth 16 --width 8 --view-width 8 \
  --lpos 16 --ldir 8 --coarse 1024 --fine 1024 --spread 20000
vector 010-widest-layer "the widest trunk (1024) in a one-layer network" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --depth 1 --width 1024 --view-width 0 \
  --coarse 8 --fine 0

# Broken streams, and the two edits a decoder must accept.
$build/tests/make_invalid vectors/invalid "$tmp" >&2
CAMS="--orbit 1 --size 12"
vector 011-minor-version-7 "a newer minor version (accepted)" \
  cp "$tmp/minor-version-7-is-accepted.cnrf" "$tmp/s.cnrf"
vector 012-unknown-ancillary-chunk "an unknown ancillary chunk (skipped)" \
  cp "$tmp/unknown-ancillary-chunk-is-skipped.cnrf" "$tmp/s.cnrf"

# Occupancy grids: a real scene's grid from the encoder, grids of several
# resolutions (one that divides no power of two) on a fog that fills the box, empty and full.
CAMS="--dataset $data/lego --downscale 8 --every 100"
vector 013-lego-encode-grid "a real scene's occupancy grid from cnerf encode (Lego, 50x50, lambda 3, 1000 iterations, 32^3 cells by --grid 32)" \
  $cnerf encode "$data/lego" -o "$tmp/s.cnrf" --lambda 3 --preset tiny --downscale 8 \
  --iters 1000 --seed $seed --threads 2 --every 100 --grid 32 --prune off --coarse-color on
CAMS="--orbit 2 --size 24"
vector 014-grid-16-ball "a 16^3 grid: a ball of occupied cells in a fog" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --grid 16
vector 015-grid-128-ball "the largest grid (128^3): a ball of occupied cells in a fog" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --grid 128
vector 016-grid-5-ball "a 5^3 grid (cell boundaries at no power of two)" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --grid 5
vector 017-grid-empty "an empty grid: every pixel is the background, no network is evaluated" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --grid 32 --grid-shape empty
vector 018-grid-full "a full grid: the same picture as without one" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --grid 32 --grid-shape full
vector 019-grid-ndc "a grid in NDC space (forward-facing)" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --grid 16 --ndc
CAMS="--dataset $data/lego --downscale 8 --every 100"
vector 020-lego-encode-pruned "dead units removed by cnerf encode, with the automatic grid (Lego, 50x50, lambda 3, 1000 iterations)" \
  $cnerf encode "$data/lego" -o "$tmp/s.cnrf" --lambda 3 --preset tiny --downscale 8 \
  --iters 1000 --seed $seed --threads 2 --every 100 --coarse-color on
CAMS="--orbit 2 --size 24"
vector 021-units "layers narrower than the width: trunk 20, 7 (into the skip), 32, 64 and a view layer of 5"  \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --units 20,7,32,64:5

# Several scenes in one stream (format 2.1): shared shifts, each scene with its own cameras.
CAMS="--orbit 2 --size 24"
SCENES="1" vector 022-two-scenes "two scenes sharing shifts (SCNS, SHFT): each scene's own bounds, background and latents" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --scenes 2 --shift-spread 1
SCENES="1" vector 023-zero-shifts "two scenes whose shifts are all 0 (each renders as its own one-scene stream)" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --scenes 2 --shift-spread 0
vector 024-one-scene-set "a set of one scene (SCNS 1) with shifts" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --scenes 1 --shift-spread 1
SCENES="1" vector 025-scenes-grid-ndc "two forward-facing scenes, each with its own occupancy grid" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --scenes 2 --ndc --grid 8
CAMS="--orbit 1 --size 12"
SCENES="254" vector 026-max-scenes "the largest scene count (255): scenes 0 and 254 checked" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --scenes 255 --depth 1 --width 4 \
  --view-width 0 --coarse 4 --fine 0 --lpos 1 --ldir 0

# Contracted scenes (format 2.2): all space beyond the inner cube drawn into the bounds.
CAMS="--orbit 2 --size 24"
vector 027-contract "a contracted scene (format 2.2): the inner half of the bounds in world space, all space beyond it drawn into the outer half" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --contract
CAMS="--dataset $data/lego --downscale 8 --every 100"
vector 028-lego-encode-contract "a real scene encoded contracted (Lego, 50x50, lambda 3, 300 iterations, --background contract)" \
  $cnerf encode "$data/lego" -o "$tmp/s.cnrf" --lambda 3 --preset tiny --downscale 8 \
  --iters 300 --seed $seed --threads 2 --every 100 --background contract --coarse-color on

# Levels (format 2.3): streams that declare one (levl), for decoders built for a level, and
# grids coded cell by cell (GRID) as the streams of formats 2.0 to 2.2 hold them.
CAMS="--orbit 2 --size 24"
vector 029-level-1 "a stream that declares level 1 (levl), its grid coded by blocks: a decoder of level 1 renders it" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --grid 32 --level 1
vector 030-level-2 "a stream that declares level 2 (4x128 networks): a decoder of level 1 refuses it with CNERF_E_LEVEL" \
  $cnerf synth -o "$tmp/s.cnrf" --preset small --view-width 64 --seed $seed --level 2
CAMS="--dataset $data/lego --downscale 8 --every 100"
vector 031-lego-encode-level-1 "a real scene encoded for level 1 by cnerf encode --level 1 (Lego, 50x50, lambda 3, 300 iterations, the automatic grid)" \
  $cnerf encode "$data/lego" -o "$tmp/s.cnrf" --lambda 3 --preset tiny --downscale 8 \
  --iters 300 --seed $seed --threads 2 --every 100 --coarse-color on --level 1
vector 032-lego-grid-cells "vector 013's grid coded cell by cell (GRID), re-coded by cnerf recode: the same pixels" \
  $cnerf recode vectors/valid/013-lego-encode-grid.cnrf -o "$tmp/s.cnrf" --grid-coding cells
CAMS="--orbit 2 --size 24"
vector 033-grid-128-cells "vector 015's 128^3 grid coded cell by cell (GRID), re-coded by cnerf recode" \
  $cnerf recode vectors/valid/015-grid-128-ball.cnrf -o "$tmp/s.cnrf" --grid-coding cells
# A small network of level 1 whose images for every kernel set are in packed/ (packed.sh).
vector 034-level-1-small "a small network of level 1 (4x16, view 8) with a 16^3 grid by blocks: packed for every kernel set in packed/" \
  $cnerf synth -o "$tmp/s.cnrf" --preset tiny --seed $seed --width 16 --view-width 8 --grid 16 --level 1

# The table of docs/conformance.md, between its markers.
python3 - <<'PY'
import os, re
rows = ["| vector | feature | bytes | level | cameras | tile MD5s | fixed vs float reference |", "|---|---|---|---|---|---|---|"]
for name in open("vectors/valid/LIST").read().split():
    t = dict(l.split(": ", 1) for l in open(f"vectors/valid/{name}.txt").read().splitlines() if ": " in l)
    size = os.path.getsize(f"vectors/valid/{name}.cnrf")
    tiles = t["tiles"].split()[0]
    vs = t["fixed point against the float reference"].split(" (")[0].replace("inf dB", "identical")
    rows.append(f"| `{name}` | {t['feature']} | {size:,} | {t['level']} | {t['cameras']} | {tiles} | {vs} |")
n_inv = sum(1 for l in open("vectors/invalid/expected.txt") if not l.startswith("#"))
doc = open("docs/conformance.md").read()
table = "\n".join(rows) + f"\n\nand {n_inv} broken streams in `invalid/`."
doc = re.sub(r"(<!-- vectors: written by vectors/regenerate.sh -->\n).*?(<!-- end of vectors -->)",
             lambda m: m.group(1) + table + "\n" + m.group(2), doc, flags=re.S)
open("docs/conformance.md", "w").write(doc)
PY

bash vectors/rgb565.sh # valid/RGB565, the first tiles in RGB565 (and the manifest)
bash vectors/lookat.sh # valid/LOOKAT, the look-at cameras (and the manifest)
bash vectors/packed.sh 034-level-1-small # packed/, images for every kernel set and broken ones
(cd vectors && find valid invalid packed -type f | LC_ALL=C sort | xargs sha256sum > MANIFEST.sha256)
echo "vectors: $(wc -l < vectors/valid/LIST) valid, $(grep -vc '^#' vectors/invalid/expected.txt) invalid; checking" >&2
$conform check vectors | tail -n 1
