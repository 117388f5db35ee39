#!/usr/bin/env bash
# experiments/web_profile.sh on vector 001: the module linked again with its names renders
# the first orbit camera in Node, and the profile names the decoder's sums among the
# functions that took the worker's time.
#   tests/web/profile.sh CNERF ROOT WEBDIR WORKDIR
set -euo pipefail
cnerf=${1:?usage: profile.sh CNERF ROOT WEBDIR WORKDIR}
root=${2:?} web=${3:?} work=${4:?}
mkdir -p "$work"
v=$root/vectors/valid/001-lego-encode-tiny.cnrf
"$cnerf" render "$v" --orbit 1 --size 24 --no-reference --save-cameras "$work/cam.txt" > /dev/null
out=$(CNERF_WEB=$web "$root/experiments/web_profile.sh" "$v" "$work/cam.txt" 2 8)
echo "$out"
grep -Eq '^renders \(ms\): [0-9.]+ [0-9.]+$' <<<"$out"
grep -Eq '^ +[0-9.]+%  cn_dot_s(8|16)_simd128$' <<<"$out"
echo "web_profile: OK"
