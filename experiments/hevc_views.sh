#!/usr/bin/env bash
# The compress-the-views baseline: the training views (as the trainer sees them, `cnerf
# views`) coded as one HEVC video (ffmpeg with libx265) in a path from each camera to its
# nearest, at each QP; the receiver decodes them and trains a NeRF on them with the same
# trainer and options (`cnerf train --train-images`). Such a receiver has to train a
# network, which a low-power device cannot; this is the paper's second comparison, with
# cnerf's trainer in place of LLFF's learned renderer.
#   experiments/hevc_views.sh OUT DATASET "QPS" [-- TRAIN OPTIONS]
# Options default to "--preset tiny --downscale 4 --iters 3000 --every 40". For each QP:
# OUT/qpQ.hevc (the raw HEVC stream, no container: its bytes are the rate), OUT/qpQ/ (the
# decoded views) and OUT/qpQ.log (the training run; a complete log is not run again, so an
# interrupted sweep resumes, a run from its checkpoint). Also OUT/uncoded.log: the same
# training on the 8-bit views before coding. Writes OUT/hevc.csv and OUT/hevc.md (QP, bytes, PSNR of the decoded views
# against the uncoded ones, the NeRF's test PSNR).
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 3 ] || { echo "usage: experiments/hevc_views.sh OUT DATASET \"QPS\" [-- OPTIONS]" >&2; exit 2; }
out=$1; data=$2; qps=$3; shift 3
[ $# -gt 0 ] && [ "$1" = "--" ] && shift
opts=("$@")
[ ${#opts[@]} -gt 0 ] || opts=(--preset tiny --downscale 4 --iters 3000 --every 40)
iters=3000; downscale=1; black=()
for ((i = 0; i < ${#opts[@]}; i++)); do
  case ${opts[$i]} in
    --iters) iters=${opts[$((i + 1))]} ;;
    --downscale) downscale=${opts[$((i + 1))]} ;;
    --black) black=(--black) ;;
  esac
done
cnerf=${CNERF:-build/cnerf}
[ -x "$cnerf" ] || { echo "hevc_views.sh: build first (scripts/test.sh)" >&2; exit 1; }
command -v ffmpeg > /dev/null || { echo "hevc_views.sh: needs ffmpeg (apt-get install ffmpeg)" >&2; exit 1; }
grep -q libx265 <<< "$(ffmpeg -hide_banner -encoders 2> /dev/null)" ||
  { echo "hevc_views.sh: this ffmpeg has no libx265" >&2; exit 1; }
mkdir -p "$out"
views=$out/views
if [ ! -s "$views/order.txt" ]; then
  "$cnerf" views "$data" -o "$views" --downscale "$downscale" "${black[@]}"
fi
# The frames in coding order, as a numbered sequence.
mapfile -t order < "$views/order.txt"
rm -rf "$out/seq"; mkdir -p "$out/seq"
for k in "${!order[@]}"; do ln -s "../views/${order[$k]}" "$(printf '%s/seq/%04d.png' "$out" "$k")"; done

train() { # LOG IMAGES
  if ! grep -q "^eval: iteration $iters," "$1" 2> /dev/null; then
    echo "hevc_views.sh: training on $2" >&2
    # an interrupted training continues from its checkpoint (train writes it to -o)
    local resume=()
    [ -s "${1%.log}.ckpt" ] && resume=(--resume)
    "$cnerf" train "$data" -o "${1%.log}.ckpt" --force --train-images "$2" --eval-every "$iters" \
      --log-every 250 "${opts[@]}" "${resume[@]}" >> "$1" 2>&1
  fi
}
for q in $qps; do
  s=$out/qp$q.hevc
  if [ ! -s "$s" ]; then
    # 4:2:0 needs even sizes: pad by a column or row, and crop it again after decoding.
    ffmpeg -hide_banner -loglevel error -y -framerate 25 -i "$out/seq/%04d.png" \
      -vf "pad=ceil(iw/2)*2:ceil(ih/2)*2" -pix_fmt yuv420p -c:v libx265 -preset veryslow \
      -x265-params "qp=$q:log-level=error" -f hevc "$s.part"
    mv "$s.part" "$s"
  fi
  d=$out/qp$q
  if [ ! -s "$d/${order[0]}" ]; then
    rm -rf "$d" "$d.seq"; mkdir -p "$d" "$d.seq"
    IFS=x read -r w h < <(ffprobe -v error -show_entries stream=width,height -of csv=p=0:s=x \
                      "$views/0000.png")
    ffmpeg -hide_banner -loglevel error -y -i "$s" -vf "format=rgb24,crop=$w:$h:0:0" -pix_fmt rgb24 \
      "$d.seq/%04d.png"
    for k in "${!order[@]}"; do mv "$(printf '%s.seq/%04d.png' "$d" $((k + 1)))" "$d/${order[$k]}"; done
    rmdir "$d.seq"
  fi
  train "$out/qp$q.log" "$d"
done
train "$out/uncoded.log" "$views" # the control, last: an interrupted sweep has the QPs first
csv=$out/hevc.csv
echo "qp,hevc_bytes,views_psnr_db,test_psnr_db" > "$csv"
psnr_of() { awk '/^eval: iteration/ { p = $9 } END { print p }' "$1"; }
echo "uncoded,,,$(psnr_of "$out/uncoded.log")" >> "$csv"
for q in $qps; do
  # The decoded views against the uncoded ones, over all frames (ffmpeg's psnr filter).
  vp=$(ffmpeg -hide_banner -framerate 25 -i "$out/qp$q/%04d.png" -framerate 25 \
         -i "$views/%04d.png" -lavfi psnr -f null - 2>&1 | sed -nE 's/.* average:([0-9.inf]+).*/\1/p')
  echo "$q,$(stat -c %s "$out/qp$q.hevc"),$vp,$(psnr_of "$out/qp$q.log")" >> "$csv"
done
{
  echo "| QP | HEVC stream (bytes) | decoded views (dB) | NeRF trained on them, test PSNR (dB) |"
  echo "|---|---|---|---|"
  tail -n +2 "$csv" | awk -F, '{ printf "| %s | %s | %s | %s |\n", $1, $2 == "" ? "–" : $2, $3 == "" ? "–" : $3, $4 }'
} > "$out/hevc.md"
cat "$out/hevc.md"
