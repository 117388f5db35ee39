#!/usr/bin/env bash
# ctests firmware_vectors_m7, _m33, _m0plus, cost_model_m4, _m55: the first tile of every
# valid conformance vector (every scene of a stream of several), rendered by the firmware of
# the core FW_CORE names under qemu-system-arm, must have the MD5 the vector lists and the
# host's. The tiles run in batches (scripts/firmware.sh --jobs): one image, one QEMU run per
# batch, with as many streams as the board's code memory holds (FW_BATCH_BYTES of streams;
# 350,000 on the M55's 512 KB ITCM, 3,000,000 on the 4 MB of the others). With TOLERANCE
# (all five ctests: 0.20), the cost model (platform/host/cost_model.c) must also be within it of
# QEMU's count (the model takes the host's count of the core's work, cnerf_open_as), and the
# firmware's count of the first tile of the first batch must be the host's (FW_WORK=first:
# every other tile is rendered once).
# Two kinds of tile are rendered on their first ray only, which must be the host's (the
# stream is opened whole, and the ray's pixel is bit-exact or it is not): a vector whose
# first tile has the MD5 of one rendered earlier in the run (the same pixels, through a
# different coding: the core rendered them whole already), and, on every core but the M4,
# a tile at the format's largest limits (1,024 coarse or fine samples a ray, vector 009: its
# first ray evaluates 1,905 samples at every layer's widest accumulators; the M4 renders the
# tile whole, as do conformance and scripts/xarch.sh with the portable C).
#   FW_CORE=m7|m33|m0plus|m4|m55 vectors.sh BUILD_DIR [TOLERANCE]
set -euo pipefail
build=$1 tol=${2:-}
root=$(cd "$(dirname "$0")/../.." && pwd)
vectors=$root/vectors/valid
core=${FW_CORE:-${FW_BOARD:-m4}}
case $core in m55|an547) budget=${FW_BATCH_BYTES:-350000} ;; *) budget=${FW_BATCH_BYTES:-3000000} ;; esac
mkdir -p "$build"
rm -f "$build".batch*.jobs
batch=0 bytes=0 count=0 rays=0 last=""
declare -A seen
for md5 in "$vectors"/*.md5; do
  name=$(basename "$md5" .md5)
  scene=0 stream=$name
  case $name in *.s[0-9]*) scene=${name##*.s} stream=${name%.s*} ;; esac
  read -r cam x0 y0 w h nc nf ts want < <(head -n 1 "$md5")
  # the first ray only, compared with the host's (above)
  label=$name
  if [ -n "${seen[$want]:-}" ] || { [ "$core" != m4 ] && [ "$core" != an386 ] &&
                                    { [ "$nc" -ge 1024 ] || [ "$nf" -ge 1024 ]; }; }; then
    label=$name.ray want=- w=1 h=1 rays=$((rays + 1))
  else
    seen[$want]=$name
  fi
  size=$(stat -c %s "$vectors/$stream.cnrf")
  if [ "$stream" != "$last" ]; then
    if [ $bytes -gt 0 ] && [ $((bytes + size)) -gt "$budget" ]; then
      batch=$((batch + 1)) bytes=0
    fi
    bytes=$((bytes + size)) last=$stream
  fi
  echo "$label $want $vectors/$stream.cnrf $scene $vectors/$name.cam $cam $x0 $y0 $w $h $nc $nf $ts" \
    >> "$build.batch$batch.jobs"
  count=$((count + 1))
done
# and vector 001's first tile in RGB565, both byte orders (valid/RGB565)
while read -r name cam x0 y0 w h nc nf ts flags want; do
  [ "$name" = 001-lego-encode-tiny ] || continue
  echo "$name.rgb565.$flags $want $vectors/$name.cnrf 0 $vectors/$name.cam $cam $x0 $y0 $w $h $nc $nf $ts $flags" \
    >> "$build.batch0.jobs"
  count=$((count + 1))
done < "$vectors/RGB565"
fails=0 ok=0
for jobs in "$build".batch*.jobs; do
  n=$(wc -l < "$jobs")
  # Without TOLERANCE only the MD5s are checked: no second render counting the work (FW_WORK);
  # with it, the first batch's first job's work is counted too
  work=0
  [ -n "$tol" ] && [ "$jobs" = "$build.batch0.jobs" ] && work=first
  if out=$(FW_BUILD_DIR=$build FW_TIMEOUT=3000 FW_COST_TOLERANCE=$tol FW_WORK=$work \
             "$root/scripts/firmware.sh" --jobs "$jobs" < /dev/null 2>&1); then
    grep -E '^[0-9]{3}-' <<<"$out" || true
    ok=$((ok + n))
  else
    echo "$out" | tail -n 40
    echo "FAIL: the batch $jobs"
    fails=$((fails + n))
  fi
done
echo "$core: $ok of the $count vectors' first tiles in $((batch + 1)) firmware run(s), $((count - rays)) of them whole with the vector's MD5${tol:+ and the cost model within $tol of the count by QEMU}, $rays on their first ray with the host's"
[ "$ok" = "$count" ] || echo "FAIL: $fails of the $count tiles"
[ "$fails" = 0 ] && [ "$ok" = "$count" ]
