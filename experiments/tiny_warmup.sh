#!/usr/bin/env bash
# The learning rate's warm-up in preset tiny's encodes (docs/training.md, "The float phase"):
# each scene encoded with --preset tiny to --size 30000 in 2000 iterations with the float
# phase, once with a warm-up of 20 iterations (--lr-warmup 20, the default before tiny's was
# 0) and once without (--lr-warmup 0, tiny's default now); one thread, --max-size 100, seed 1.
# Each file is scored on the scene's test views by `cnerf eval FILE SCENE --max-size 100`;
# the difference is the mean over the views of each view's difference, with its standard
# error. Resumable: a file already scored is not encoded again.
#   experiments/tiny_warmup.sh [--table] OUT SCENE_DIR ...
# Writes OUT/tiny_warmup.md; --table only tabulates the runs already in OUT (a missing one:
# "not run").
set -euo pipefail
cd "$(dirname "$0")/.."
table_only=0
[ "${1:-}" = --table ] && { table_only=1; shift; }
out=${1:?usage: experiments/tiny_warmup.sh [--table] OUT SCENE_DIR ...}
shift
[ $# -gt 0 ] || { echo "tiny_warmup: no scene given" >&2; exit 2; }
cnerf=${CNERF:-./build/cnerf}
mkdir -p "$out"
for dir in "$@"; do
  scene=$(basename "$dir")
  for w in 20 0; do
    f=$out/$scene-warm$w.cnrf
    [ -s "$f.eval" ] || [ $table_only = 1 ] || {
      "$cnerf" encode "$dir" -o "$f" --force --size 30000 --preset tiny --lr-warmup "$w" \
        --iters 2000 --max-size 100 --threads 1 --seed 1 > "$f.log" 2>&1 || true
      # tiny may fall short of the size (exit 1) and still write its file
      [ -s "$f" ] && "$cnerf" eval "$f" "$dir" --max-size 100 > "$f.eval" 2>&1 || rm -f "$f.eval"
    }
  done
done
python3 - "$out" "$@" > "$out/tiny_warmup.md" <<'EOF'
import os, sys
sys.path.insert(0, 'experiments')
from eval_views import eval_views, paired
out, dirs = sys.argv[1], sys.argv[2:]
def scored(path):
    if not os.path.exists(path):
        return None
    return {k: float(v) for k, v in eval_views(path)} or None
print('| scene | warm-up 20: test PSNR, bytes | none: test PSNR, bytes | none − 20 (± standard error, views) |')
print('|---|---|---|---|')
diffs = []
for d in dirs:
    scene = os.path.basename(d.rstrip('/'))
    row, views = ['| %s |' % scene], []
    for w in (20, 0):
        f = os.path.join(out, '%s-warm%d.cnrf' % (scene, w))
        v = scored(f + '.eval')
        views.append(v)
        row.append(' not run |' if v is None else ' %.2f dB, %d B |' %
                   (sum(v.values()) / len(v), os.path.getsize(f)))
    pv = paired(*views)
    if pv is not None:
        row.append(' %+.2f ± %.2f dB (%d) |' % pv)
        diffs.append(pv[0])
    else:
        row.append(' – |')
    print(''.join(row))
if diffs:
    print()
    print('mean difference over %d scenes: %+.2f dB; without the warm-up better on %d, worse on %d'
          % (len(diffs), sum(diffs) / len(diffs), sum(x > 0 for x in diffs), sum(x < 0 for x in diffs)))
EOF
cat "$out/tiny_warmup.md"
