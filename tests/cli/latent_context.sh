#!/usr/bin/env bash
# tests/tools/latent_context on a random stream of preset tiny: a row per layer that codes
# latents, whose "coded" bytes are the table and payload `cnerf info` gives that layer; the
# adaptive codes cost at least the empirical entropy (no sequential code beats it); the
# totals add up; a file that is not a stream is refused with the decoder's reason.
set -euo pipefail
cnerf=$1 tool=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }
"$cnerf" synth -o "$work/s.cnrf" --preset tiny --seed 3 > /dev/null
"$tool" "$work/s.cnrf" > "$work/t.md" || fail "tool failed: $(cat "$work/t.md")"
"$cnerf" info --no-estimate "$work/s.cnrf" > "$work/info.txt"
# info's layer rows: layer net role in->out params range prec table payload ...
awk '/^layer /{on=1; next} on && /^$/{on=0} on && NF > 8 && $6 != "[0,0]" { print $1, $8 + $9 }' \
  "$work/info.txt" > "$work/want"
awk -F'|' '$2 ~ /^ [0-9]+ $/ { gsub(/ /, ""); print $2, $5 }' "$work/t.md" > "$work/got"
[ -s "$work/want" ] || fail "no layers in info: $(cat "$work/info.txt")"
cmp -s "$work/want" "$work/got" || fail "coded bytes differ from cnerf info: $(paste "$work/want" "$work/got")"
awk -F'|' '$2 ~ /^ [0-9]+ $/ { for (m = 7; m <= 10; m++) if ($m + 0 < $6 - 0.5) { print "layer " $2 ": code " m " below the entropy"; bad = 1 } }
  $2 ~ /all/ { for (m = 5; m <= 10; m++) total[m] = $m }
  $2 ~ /^ [0-9]+ $/ { for (m = 5; m <= 10; m++) sum[m] += $m }
  END { for (m = 5; m <= 10; m++) if (sum[m] - total[m] > 8 || total[m] - sum[m] > 8) { print "column " m ": rows " sum[m] ", total " total[m]; bad = 1 }
        exit bad }' "$work/t.md" || fail "$(cat "$work/t.md")"
grep -q "^best context model: " "$work/t.md" && grep -q "^the best of the four for each layer: " "$work/t.md" ||
  fail "summary lines: $(cat "$work/t.md")"
# A file that is not a stream.
head -c 100 "$work/info.txt" > "$work/bad.cnrf"
if "$tool" "$work/bad.cnrf" > "$work/bad.out" 2>&1; then fail "a text file was read as a stream"; fi
grep -q "^latent_context: .*bad.cnrf: " "$work/bad.out" || fail "message: $(cat "$work/bad.out")"
if "$tool" > /dev/null 2>&1; then fail "no argument accepted"; fi
echo "latent_context: $(tail -2 "$work/t.md" | tr '\n' ' ')"
