#!/usr/bin/env bash
# The shared scenes with fewer views, for the command-line tests: each run of cnerf reads and
# decodes every training and validation image of its scene, and Lego and Mic have 100 of
# each. OUT/lego and OUT/mic list every 10th training and validation view of the shared
# scene (10 + 10; the test views all, as the tests choose among them with --every); their
# images, and OUT/fern and OUT/horns, are hard links to the shared files (cp -al: a test that
# removes or renames a file of OUT leaves the shared scene as it was). Prints OUT.
#   few_views.sh DATA OUT
set -euo pipefail
data=$1 out=$2
rm -rf "$out" && mkdir -p "$out"
for scene in lego mic; do
  mkdir "$out/$scene"
  for part in train val test; do
    cp -al "$data/$scene/$part" "$out/$scene/$part"
  done
  python3 - "$data/$scene" "$out/$scene" <<'PY'
import json, sys
src, dst = sys.argv[1], sys.argv[2]
for part in ('train', 'val', 'test'):
    with open(f'{src}/transforms_{part}.json') as f:
        j = json.load(f)
    if part != 'test':
        j['frames'] = j['frames'][::10]
    with open(f'{dst}/transforms_{part}.json', 'w') as f:
        json.dump(j, f, indent=1)
PY
done
for scene in fern horns; do
  cp -al "$data/$scene" "$out/$scene"
done
echo "$out"
