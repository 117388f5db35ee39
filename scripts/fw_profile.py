#!/usr/bin/env python3
"""Instructions executed per function, from QEMU's execution trace of a firmware run
(qemu-system-arm -d in_asm,exec,nochain -D TRACE; scripts/firmware.sh FW_PROFILE=FILE).

    scripts/fw_profile.py TRACE [START_FUNCTION]

in_asm prints each translated block once, with its instructions; exec prints a line each
time a block runs, with its guest address and function. A block's instructions are counted
each time it runs (the latest translation at that address: QEMU may translate an address
again). With START_FUNCTION, counting starts at the first block of that function. Prints the
total, then every function with its instructions and share, the largest first."""
import collections
import re
import sys


def main():
    if len(sys.argv) not in (2, 3):
        sys.exit(__doc__)
    start = sys.argv[2] if len(sys.argv) == 3 else None
    size = {}                 # a block's address -> its instructions
    pending, n = None, 0      # the block being read from in_asm
    counts = collections.Counter()
    started = start is None
    trace = re.compile(r'^Trace \d+: 0x[0-9a-f]+ \[[0-9a-f]+/([0-9a-f]+)/[0-9a-f]+/[0-9a-f]+\] (\S*)')
    with open(sys.argv[1], errors='replace') as f:
        for line in f:
            if line.startswith('IN:'):
                pending, n = None, 0
            elif line.startswith('0x'):
                if pending is None:
                    pending = int(line[2:line.index(':')], 16)
                n += 1
            elif line.startswith('Trace'):
                if pending is not None:
                    size[pending], pending = n, None
                m = trace.match(line)
                if not m:
                    continue
                pc, fn = int(m.group(1), 16), m.group(2) or '?'
                if not started:
                    if fn != start:
                        continue
                    started = True
                if pc not in size:
                    sys.exit('fw_profile.py: a block at 0x%x ran before its translation was seen' % pc)
                counts[fn] += size[pc]
            elif not line.strip() and pending is not None:
                size[pending], pending = n, None
    if not started:
        sys.exit('fw_profile.py: %s never ran' % start)
    total = sum(counts.values())
    print('instructions from the first block of %s on: %d' % (start or 'the run', total))
    print('%14s %7s  %s' % ('instructions', 'share', 'function'))
    for fn, c in counts.most_common():
        print('%14d %6.2f%%  %s' % (c, 100.0 * c / total, fn))


if __name__ == '__main__':
    main()
