#!/usr/bin/env bash
# The measured tables of docs/firmware.md: the memory and flash map of each preset on the
# Cortex-M4 (a stream of the preset's topology from `cnerf synth`, one pixel rendered by the
# firmware, scripts/firmware.sh, -Os), and the time of a frame on each core (vector 013, a
# Lego encode with a 32^3 occupancy grid, its view r_0 rendered whole at 25x25, half the
# vector's resolution, with the stream's default knobs, instructions per ray by QEMU; the
# time of a 100x100 frame at the part's clock, at one instruction per cycle).
#   scripts/firmware_doc.sh            prints the tables
#   scripts/firmware_doc.sh --check    fails unless docs/firmware.md holds them as measured
# CNERF: the host program (build/cnerf). FW_DOC_BUILD: the build directory (build-fwdoc).
set -euo pipefail
cd "$(dirname "$0")/.."
check=0
[ "${1:-}" = "--check" ] && check=1
cnerf=${CNERF:-build/cnerf}
bd=${FW_DOC_BUILD:-build-fwdoc}
[ -x "$cnerf" ] || { echo "firmware_doc.sh: $cnerf: no such program (build the tree first)" >&2; exit 1; }
mkdir -p "$bd"
table=$bd/tables.md
num() { tr -d , <<< "$1"; }
fmt() { python3 -c "import sys; print(f'{int(sys.argv[1]):,}')" "$1"; }
{
  echo "| preset (topology) | flash: code (decoder and test firmware) | flash: constants | flash: stream (unconstrained) | RAM: workspace | RAM: render scratch | RAM: \`cnerf_decoder\` | RAM: worst-case stack | RAM in all |"
  echo "|---|---|---|---|---|---|---|---|---|"
  for preset in tiny small paper; do
    s=$bd/$preset.cnrf
    "$cnerf" synth -o "$s" --preset "$preset" --seed 1 > /dev/null
    "$cnerf" info --no-estimate "$s" > "$bd/$preset.info"
    topo=$(sed -n 's/^network 1 (fine): depth \([0-9]*\), width \([0-9]*\),.*/\1x\2/p' "$bd/$preset.info")
    [ -n "$topo" ] || topo=$(sed -n 's/^network 0 [^:]*: depth \([0-9]*\), width \([0-9]*\),.*/\1x\2/p' "$bd/$preset.info")
    samples=$(sed -n 's/^samples: \([0-9]*\) coarse + \([0-9]*\) fine/\1+\2/p' "$bd/$preset.info")
    # one pixel, from the camera r_0 of vector 001 (Lego's bounds, as synth's)
    grep -E '[[:space:]]r_0$' vectors/valid/001-lego-encode-tiny.cam > "$bd/pixel.cam"
    out=$(FW_CORE=m4 FW_BUILD_DIR=$bd/m4 FW_TIMEOUT=3000 FW_WORK=0 FW_STACK=8192 \
          scripts/firmware.sh "$s" "$bd/pixel.cam" "8 8 1 1" 2>&1) || { echo "$out" >&2; exit 1; }
    fl=$(grep '^flash ' <<< "$out") ram=$(grep '^RAM ' <<< "$out")
    code=$(sed -n 's/^flash [0-9,]* bytes: code \([0-9,]*\) .*/\1/p' <<< "$fl")
    const=$(sed -n 's/.*constants \([0-9,]*\) .*/\1/p' <<< "$fl")
    stream=$(sed -n 's/.*embedded stream \([0-9,]*\),.*/\1/p' <<< "$fl")
    ws=$(sed -n 's/.*(workspace \([0-9,]*\),.*/\1/p' <<< "$ram")
    sc=$(sed -n 's/.*render scratch \([0-9,]*\),.*/\1/p' <<< "$ram")
    dec=$(sed -n 's/.*cnerf_decoder \([0-9,]*\),.*/\1/p' <<< "$ram")
    stack=$(sed -n 's/^stack worst case \([0-9,]*\) bytes.*/\1/p' <<< "$out")
    all=$(( $(num "$ws") + $(num "$sc") + $(num "$dec") + $(num "$stack") ))
    echo "| $preset ($topo, $samples samples) | $code | $const | $stream | $ws | $sc | $dec | $stack | $(fmt $all) |"
  done
  echo
  echo "| core | QEMU board | instructions per ray, vector 013's view r_0 whole at 25x25 | per MAC | example part | clock | a 100x100 frame at one instruction per cycle |"
  echo "|---|---|---|---|---|---|---|"
  v=vectors/valid/013-lego-encode-grid
  # r_0 at half the vector's 50x50, the same field of view in a quarter of the rays: the focal
  # lengths and the principal point halved, rounded to the camera's 1/65536 pixel
  awk '$19 == "r_0" { for (i = 13; i <= 16; i++) $i = int(($i + 1) / 2); $17 = int($17 / 2);
                      $18 = int($18 / 2); print }' "$v.cam" > "$bd/r_0.cam"
  read -r w h < <(awk '{print $17, $18}' "$bd/r_0.cam")
  [ "$w" = 25 ] && [ "$h" = 25 ] || { echo "firmware_doc.sh: $v.cam's r_0 is not 50x50" >&2; exit 1; }
  # core, example part, its clock in MHz
  for c in "m0plus:RP2040:133" "m4:STM32F407:168" "m7:STM32H743:480" "m33:STM32U575:160" "m55:Alif Ensemble E3 (high-efficiency core):160"; do
    IFS=: read -r core part mhz <<< "$c"
    # FW_WORK=0: one render; the MACs are the host's count of this core's work
    out=$(FW_CORE=$core FW_BUILD_DIR=$bd/$core FW_TIMEOUT=3000 FW_WORK=0 \
          scripts/firmware.sh "$v.cnrf" "$bd/r_0.cam" "0 0 $w $h" 2>&1) || { echo "$out" >&2; exit 1; }
    name=$(sed -n 's/^== cost on the target: \([^,]*\),.*/\1/p' <<< "$out")
    board=$(sed -n 's/^built .* (\([^,]*\), \([^,]*\),.*/\2/p' <<< "$out")
    ipr=$(sed -n 's/.*: \([0-9,]*\) instructions per ray.*/\1/p' <<< "$out")
    ipm=$(sed -n 's/.*instructions per MAC: \([0-9.]*\) .*/\1/p' <<< "$out")
    secs=$(python3 -c "print(f'{$(num "$ipr") * 10000 / ($mhz * 1e6):.1f} s')")
    echo "| $name | $board | $ipr | $ipm | $part | $mhz MHz | $secs |"
  done
} > "$table"
. scripts/doc_table.sh
doc_table "$table" docs/firmware.md $check "tables are"
