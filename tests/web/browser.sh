#!/usr/bin/env bash
# The browser test's fixtures, then the test (tests/web/browser.mjs):
#   browser.sh CNERF DATA WEBDIR VECTORS WORK [SCREENSHOT]
# The stream is the README main job's (scripts/demo.sh's encode command) at 100 iterations
# instead of 2000; `cnerf render` writes its image and camera of test view r_0, `cnerf html`
# its single file. STREAM=FILE in the environment takes that stream instead (a Lego one: the
# test compares test view r_0). The screenshot in README.md and docs/web.md:
#   STREAM=out/lego.cnrf tests/web/browser.sh build/cnerf ../shared/data build/web vectors \
#     /tmp/web docs/img/viewer.png
set -euo pipefail
cnerf=$1 data=$2 web=$3 vectors=$4 work=$5 shot=${6:-}
rm -rf "$work" && mkdir -p "$work"
if [ -n "${STREAM:-}" ]; then
  cp "$STREAM" "$work/lego.cnrf"
else
  "$cnerf" encode "$data/lego" -o "$work/lego.cnrf" --lambda 0.1 --preset tiny --downscale 4 \
    --iters 100 --every 40 --log-every 100 > "$work/encode.log"
fi
"$cnerf" render "$work/lego.cnrf" --dataset "$data/lego" --downscale 4 --every 200 \
  -o "$work/render" --save-cameras "$work/cams" > "$work/render.log"
"$cnerf" html "$work/lego.cnrf" -o "$work/lego.html"
node "$(dirname "$0")/browser.mjs" "$web" "$vectors" "$work/lego.cnrf" "$work/cams" \
  "$work/render/r_0.png" "$work/lego.html" $shot
