#!/usr/bin/env bash
# The encoder's float phase (docs/training.md, "The float phase"): each scene encoded with
# presets tiny and small to --size 30000 in 2000 iterations, once rounded from the first
# iteration (--float-iters 0, the former training) and once with the default float phase (a
# quarter of the run unrounded, with the warm-up); one thread, --max-size 100, seed 1. The
# encode's own test line (the float reference of the file on the scene's test views) scores
# each. Resumable: a file already written is not encoded again.
#   experiments/float_phase.sh [--table] OUT [SCENE_DIR ...]   (default: ../shared/data/lego and fern)
# Writes OUT/float_phase.md; --table only tabulates the runs already in OUT (a missing one:
# "not run").
set -euo pipefail
cd "$(dirname "$0")/.."
table_only=0
[ "${1:-}" = --table ] && { table_only=1; shift; }
out=${1:?usage: experiments/float_phase.sh [--table] OUT [SCENE_DIR ...]}
shift
[ $# -gt 0 ] || set -- ../shared/data/lego ../shared/data/fern
cnerf=${CNERF:-./build/cnerf}
mkdir -p "$out"
md=$out/float_phase.md
{
  echo "| scene | preset | rounded from the start: test PSNR, bytes | float phase: test PSNR, bytes | difference |"
  echo "|---|---|---|---|---|"
} > "$md"
for dir in "$@"; do
  scene=$(basename "$dir")
  for preset in tiny small; do
    row="| $scene | $preset |" psnrs=()
    for phase in 0 default; do
      f=$out/$scene-$preset-$phase.cnrf
      opt=()
      [ "$phase" = default ] || opt=(--float-iters "$phase")
      [ -s "$f" ] || [ $table_only = 1 ] || "$cnerf" encode "$dir" -o "$f" --force --size 30000 --preset "$preset" \
        --iters 2000 --max-size 100 --threads 1 --seed 1 "${opt[@]}" > "$f.log" 2>&1 || true
      p=""
      [ ! -e "$f.log" ] || p=$(sed -n 's/^test: .* psnr \([0-9.]*\) dB.*/\1/p' "$f.log" | tail -n 1)
      if [ -s "$f" ] && [ -n "$p" ]; then
        row="$row $p dB, $(stat -c %s "$f") B |"
        psnrs+=("$p")
      elif [ ! -e "$f.log" ]; then
        row="$row not run |"
      elif grep -q "the model has not found the scene (fog)" "$f.log"; then
        v=$(sed -n 's/.*its validation PSNR \([0-9.]*\) dB.*/\1/p' "$f.log")
        row="$row refused: fog (validation $v dB) |"
      else
        row="$row failed (see $f.log) |"
      fi
    done
    if [ ${#psnrs[@]} = 2 ]; then
      row="$row $(python3 -c "print('%+.2f dB' % (${psnrs[1]} - ${psnrs[0]}))") |"
    else
      row="$row – |"
    fi
    echo "$row" >> "$md"
  done
done
cat "$md"
