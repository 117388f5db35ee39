#!/usr/bin/env bash
# scripts/fw_profile.py on a made trace: blocks counted each time they run, the latest
# translation of an address, nothing before the start function, and the errors.
set -euo pipefail
root=${1:?usage: fw_profile.sh ROOT WORKDIR}
work=${2:?usage: fw_profile.sh ROOT WORKDIR}
mkdir -p "$work"
t=$work/trace.log
cat > "$t" <<'TRACE'
----------------
IN: main
0x00000100:  b508       push     {r3, lr}
0x00000102:  f000 f801  bl       #0x108

Trace 0: 0x7f0000000100 [00800408/00000100/00000110/ff020200] main
----------------
IN: render
0x00000200:  2100       movs     r1, #0
0x00000202:  3101       adds     r1, #1
0x00000204:  4770       bx       lr

Trace 0: 0x7f0000000200 [00800408/00000200/00000110/ff020200] render
----------------
IN: dot
0x00000300:  fb21 3002  smlad    r0, r1, r2, r3
0x00000304:  d1fc       bne      #0x300

Trace 0: 0x7f0000000300 [00800408/00000300/00000110/ff020200] dot
Trace 0: 0x7f0000000300 [00800408/00000300/00000110/ff020200] dot
Trace 0: 0x7f0000000300 [00800408/00000300/00000110/ff020200] dot
Trace 0: 0x7f0000000100 [00800408/00000100/00000110/ff020200] main
----------------
IN: dot
0x00000300:  fb21 3002  smlad    r0, r1, r2, r3

Trace 0: 0x7f0000000300 [00800408/00000300/00000110/ff020200] dot
TRACE
out=$(python3 "$root/scripts/fw_profile.py" "$t" render)
echo "$out"
# render 3; dot 3 x 2 + 1 (translated again, one instruction); main 2 after the start
grep -q '^instructions from the first block of render on: 12$' <<<"$out"
grep -Eq '^ +7 +58\.33%  dot$' <<<"$out"
grep -Eq '^ +3 +25\.00%  render$' <<<"$out"
grep -Eq '^ +2 +16\.67%  main$' <<<"$out"
all=$(python3 "$root/scripts/fw_profile.py" "$t")
grep -q '^instructions from the first block of the run on: 14$' <<<"$all"
if python3 "$root/scripts/fw_profile.py" "$t" nowhere 2> "$work/err"; then
  echo "a start function that never ran was accepted" >&2
  exit 1
fi
grep -q 'nowhere never ran' "$work/err"
echo "fw_profile: OK"
