#!/usr/bin/env bash
# --preset auto's trials on each scene of a scene list (docs/results.md, "Every scene a user
# brings"): the encode the suite runs (--max-size 100, one thread, seed 1), at a size where the
# bits rule picks small so that the trials are made, stopped once they have printed:
#   experiments/auto_trials.sh OUT SCENES [SIZE] [ITERS]
# SCENES: lines of name, kind and folder, as experiments/scene_suite.sh takes them. SIZE
# defaults to 60000 bytes, ITERS to 2000 (trials of a tenth of that). OUT/auto_trials.csv
# gets a row per scene: the trials' validation PSNRs and auto's choice. Scenes with a row are
# not run again. CNERF names the binary (default build/cnerf).
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: experiments/auto_trials.sh OUT SCENES [SIZE] [ITERS]}
list=${2:?scene list} size=${3:-60000} iters=${4:-2000}
cnerf=${CNERF:-build/cnerf}
mkdir -p "$out"
csv=$out/auto_trials.csv
[ -s "$csv" ] || echo "scene,iters,size,trial_iters,small_val,tiny_val,choice,seconds" > "$csv"
while read -r name _ dir; do
  [ -n "$name" ] && [ "${name:0:1}" != "#" ] || continue
  grep -q "^$name,$iters,$size," "$csv" && continue
  log=$out/$name-$iters-$size.log
  "$cnerf" encode "$dir" -o "$out/$name.cnrf" --size "$size" --iters "$iters" --max-size 100 \
    --threads 1 --seed 1 --force > "$log" 2>&1 &
  pid=$!
  while kill -0 "$pid" 2>/dev/null; do
    grep -q '^preset auto: trials of\|^encoding ' "$log" && { kill "$pid"; break; }
    sleep 2
  done
  wait "$pid" 2>/dev/null || true
  rm -f "$out/$name.cnrf" "$out/$name.cnrf.ckpt"
  line=$(grep '^preset auto: trials of' "$log" || true)
  if [ -z "$line" ]; then
    echo "$name: no trials ($(grep '^preset auto' "$log" | head -n 1))" >&2
    continue
  fi
  # preset auto: trials of N iterations (S s), validation psnr small A dB, tiny B dB: CHOICE
  sed -E "s/^preset auto: trials of ([0-9]+) iterations \(([0-9]+) s\), validation psnr small ([0-9.]+) dB, tiny ([0-9.]+) dB: ([a-z]+)$/$name,$iters,$size,\1,\3,\4,\5,\2/" \
    <<<"$line" >> "$csv"
done < "$list"
column -s, -t "$csv"
