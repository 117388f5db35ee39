#!/usr/bin/env bash
# Every core's figures on the same tiles, as one table: the decoder as firmware
# (scripts/firmware.sh, -Os) on the Cortex-M0+, M4, M7, M33 and M55 under QEMU, rendering the
# first tile of vector 001 and the tile (16, 16) of vector 013, each with the MD5 the vector
# lists: instructions per ray and per multiply-accumulate, code and worst-case stack; then
# the memory of vector 001's tile on each core (flash and RAM, as firmware.sh prints them).
#   scripts/cores.sh             prints the markdown table
#   scripts/cores.sh --check     fails unless docs/decoder.md holds the table as measured
# (docs/decoder.md, "Cores"). Each core builds in build-cores/<core> (CORES_BUILD: another
# directory than build-cores).
set -euo pipefail
cd "$(dirname "$0")/.."
check=0
[ "${1:-}" = "--check" ] && check=1
bd=${CORES_BUILD:-build-cores}
table=$(mktemp)
trap 'rm -f "$table"' EXIT
# tile: vector, line of its .md5
tiles=("001-lego-encode-tiny 1" "013-lego-encode-grid 6")
declare -A mem
names=()
{
  echo "| core (QEMU board) | code, vector 001's firmware (bytes) | stack, worst case (bytes) | vector 001, tile (0, 0): instructions per ray | per MAC | vector 013, tile (16, 16): instructions per ray | per MAC |"
  echo "|---|---|---|---|---|---|---|"
  for core in m0plus m4 m7 m33 m55; do
    row="" code="" stack=""
    for t in "${tiles[@]}"; do
      # code and stack: of the first tile's firmware (each embeds its own stream)
      read -r vec line <<< "$t"
      read -r cam x0 y0 w h nc nf ts md5 < <(sed -n "${line}p" "vectors/valid/$vec.md5")
      mkdir -p "$bd"
      grep -E "[[:space:]]$cam\$" "vectors/valid/$vec.cam" > "$bd/$core.cam"
      # FW_WORK=0: one render; the MACs are the host's count of this core's work
      out=$(FW_CORE=$core FW_BUILD_DIR=$bd/$core FW_EXPECT_MD5=$md5 FW_TIMEOUT=3000 FW_WORK=0 \
            scripts/firmware.sh "vectors/valid/$vec.cnrf" "$bd/$core.cam" \
            "$x0 $y0 $w $h" "$nc" "$nf" "$ts" 2>&1) || { echo "$out" >&2; exit 1; }
      name=$(sed -n 's/^== cost on the target: \([^,]*\),.*/\1/p' <<< "$out")
      board=$(sed -n 's/^built .* (\([^,]*\), \([^,]*\),.*/\2/p' <<< "$out")
      [ -n "$code" ] || code=$(sed -n 's/^flash [0-9,]* bytes: code \([0-9,]*\) .*/\1/p' <<< "$out")
      [ -n "$stack" ] || stack=$(sed -n 's/^stack worst case \([0-9,]*\) bytes.*/\1/p' <<< "$out")
      ipr=$(sed -n 's/.*: \([0-9,]*\) instructions per ray.*/\1/p' <<< "$out")
      ipm=$(sed -n 's/.*instructions per MAC: \([0-9.]*\) .*/\1/p' <<< "$out")
      row="$row | $ipr | $ipm"
      if [ "$vec" = "${tiles[0]%% *}" ]; then
        fl=$(grep '^flash ' <<< "$out") ram=$(grep '^RAM ' <<< "$out")
        st=$(grep '^stack worst case ' <<< "$out")
        mem[$core,code]=$code
        mem[$core,const]=$(sed -n 's/.*constants \([0-9,]*\) .*/\1/p' <<< "$fl")
        mem[$core,stream]=$(sed -n 's/.*embedded stream \([0-9,]*\),.*/\1/p' <<< "$fl")
        mem[$core,ws]=$(sed -n 's/.*(workspace \([0-9,]*\),.*/\1/p' <<< "$ram")
        mem[$core,scratch]=$(sed -n 's/.*render scratch \([0-9,]*\),.*/\1/p' <<< "$ram")
        mem[$core,dec]=$(sed -n 's/.*cnerf_decoder \([0-9,]*\),.*/\1/p' <<< "$ram")
        mem[$core,stack]=$(sed -n 's/^stack worst case \([0-9,]*\) bytes .* = thread \([0-9]*\) .* + SysTick \([0-9]*\)+\([0-9]*\) + fault \([0-9]*\)+\([0-9]*\); measured high-water \([0-9]*\)$/\1 (chain \2, measured \7)/p' <<< "$st")
      fi
    done
    names+=("$name")
    echo "| $name ($board) | $code | $stack$row |"
  done
  echo
  cores=(m0plus m4 m7 m33 m55)
  hdr="| vector 001's tile: bytes |"
  for nm in "${names[@]}"; do hdr="$hdr $nm |"; done
  echo "$hdr"
  echo "|---|---|---|---|---|---|"
  for k in "code:flash: code (decoder, runner, startup, vector table)" \
           "const:flash: constants (the decoder's sin, 2^−x and sigmoid tables: 4,108)" \
           "stream:flash: the embedded stream" \
           "ws:RAM: workspace (latents as int8 where their range allows, else int16; biases, row orders)" \
           "scratch:RAM: render scratch" "dec:RAM: \`cnerf_decoder\`" \
           "stack:RAM: worst-case stack: the deepest call chain and the SysTick and fault exception frames (the chain alone; the high-water mark measured)"; do
    line="| ${k#*:} |"
    for c in "${cores[@]}"; do line="$line ${mem[$c,${k%%:*}]} |"; done
    echo "$line"
  done
} > "$table"
. scripts/doc_table.sh
doc_table "$table" docs/decoder.md $check "table of the cores is"
