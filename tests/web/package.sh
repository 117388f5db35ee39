#!/usr/bin/env bash
# The JavaScript package as npm packs it: WEBDIR/js (platform/web/build.sh) must pack with its
# module, types, viewer and WebAssembly decoder, and nothing else.
#   package.sh WEBDIR
set -euo pipefail
cd "$1/js"
got=$(npm pack --dry-run --json 2> /dev/null |
  python3 -c 'import json, sys; print(" ".join(sorted(f["path"] for f in json.load(sys.stdin)[0]["files"])))')
want="cnerf.wasm core.js index.d.ts index.js package.json viewer.js"
[ "$got" = "$want" ] || { echo "FAIL: npm pack's files: $got; want $want" >&2; exit 1; }
echo "npm pack: $got"
