#!/usr/bin/env bash
# Writes vectors/valid/LOOKAT: cameras made by cnerf_camera_look_at from fixed integer inputs
# (orbits, non-square images, the field of view's range, far and near eyes, the largest
# coordinates) and the refusals, with this tree's decoder (vectors/tools/lookat.c), then
# MANIFEST.sha256 again. vectors/regenerate.sh runs it.
set -euo pipefail
cd "$(dirname "$0")/.."
tool=$(mktemp -d)
trap 'rm -rf "$tool"' EXIT
cc -std=c99 -O2 -Wall -Wextra -Werror -pedantic -Iinclude decoder/*.c vectors/tools/lookat.c \
  -o "$tool/lookat"
"$tool/lookat" > vectors/valid/LOOKAT.new
mv vectors/valid/LOOKAT.new vectors/valid/LOOKAT
(cd vectors && find valid invalid $([ -d packed ] && echo packed) -type f | LC_ALL=C sort | xargs sha256sum > MANIFEST.sha256)
echo "vectors/lookat.sh: $(wc -l < vectors/valid/LOOKAT) look-at cases in vectors/valid/LOOKAT" >&2
