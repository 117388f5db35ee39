#!/usr/bin/env python3
"""Replays --preset auto's race on the scene suite's courses (scene_suite.sh --trajectories):
for each scene whose two presets' courses are both there (the race's validations, then the
winner's default encode and the other preset's encode alone), prints both presets'
validation PSNR and size every 100 iterations, small's mean lead over the three validations
up to half the run, and the same lead over the validations where small is within TOL of its
target size (the rule "wait until small is at its size"), at the last validation, and three
rules' verdicts:
- the race's (cn_race_step in encoder/compress/autopreset.c): from 15% of the run a mean lead
  beyond 1 dB over the last 3 validations, else the leader at half the run; a lead of
  small's counts only where small was within 5% of its size at each of the 3, and when
  small leads at half the run away from its size, the leader over the first 3 validations
  at its size wins;
- the race's before sizes counted: the same without the size;
- "at size": a lead counts only when the leader was within TOL of its size at each of
  those 3 validations, and from half the run only when both were; at the end of the run
  the leader wins.

  experiments/race_replay.py experiments/data/scene_suite_trajectories.csv [--tol 0.05]

An "iter N" line's val is the validation made 100 iterations before N (the encodes validate
every 100); its size is the size at N."""
import csv, sys
from collections import defaultdict

path = sys.argv[1]
tol = float(sys.argv[sys.argv.index('--tol') + 1]) if '--tol' in sys.argv else 0.05
rows = list(csv.DictReader(open(path)))
# The winner is the preset with no encode of its own: its course is the default encode's.
alone = defaultdict(set)
for r in rows:
    if r['run'] in ('encode-tiny', 'encode-small'):
        alone[(r['scene'], int(r['iters']), int(r['target']))].add(r['run'][len('encode-'):])
V = defaultdict(lambda: {'tiny': {}, 'small': {}})  # key -> preset -> step -> validation PSNR
S = defaultdict(lambda: {'tiny': {}, 'small': {}})  # key -> preset -> step -> size (kB)
for r in rows:
    key, n = (r['scene'], int(r['iters']), int(r['target'])), int(r['iter'])
    if r['run'].startswith('race-'):
        p, step = r['run'][len('race-'):], n
    else:
        p = r['run'][len('encode-'):]
        if p == 'default':
            others = {'tiny', 'small'} - alone[key]
            if len(others) != 1:
                continue
            p = others.pop()
        step = n - 100
        S[key][p].setdefault(n, float(r['size_kb']))
        V[key][p].setdefault(step, float(r['val_psnr']))
        continue
    V[key][p][step] = float(r['val_psnr'])
    S[key][p][step] = float(r['size_kb'])


def lead(key, steps):
    t = [V[key]['tiny'].get(n) for n in steps]
    s = [V[key]['small'].get(n) for n in steps]
    if not steps or None in t + s:
        return None
    return sum(s) / len(s) - sum(t) / len(t)


for key in sorted(V):
    scene, iters, target = key
    common = sorted(set(V[key]['tiny']) & set(V[key]['small']))
    if not common or max(common) < iters // 2:
        continue
    print('%s, %d iterations, %d B:' % key)
    for n in common:
        print('  %5d  tiny %6.2f dB %6.2f kB   small %6.2f dB %6.2f kB' %
              (n, V[key]['tiny'][n], S[key]['tiny'].get(n, float('nan')), V[key]['small'][n],
               S[key]['small'].get(n, float('nan'))))
    fmt = lambda v: '-' if v is None else '%+.2f dB' % v
    half = [n for n in common if n <= iters // 2][-3:]
    at = [n for n in common if S[key]['small'].get(n, 1e9) <= (1 + tol) * target / 1000][-3:]
    print("  small's lead over the last 3 validations to half the run (%s): %s" %
          (', '.join(map(str, half)), fmt(lead(key, half))))
    print("  small's lead over the last 3 where small is within %g%% of its size (%s): %s" %
          (100 * tol, ', '.join(map(str, at)) or 'none', fmt(lead(key, at))))
    print("  small's lead at the last validation (%d): %s" % (common[-1], fmt(lead(key, common[-1:]))))
    def at_size(p, n):
        size = S[key][p].get(n)
        return size is not None and 0 < size <= (1 + tol) * target / 1000

    def replay(sizes):
        for i, n in enumerate(common):
            win = common[max(0, i - 2):i + 1]
            m = lead(key, win)
            leader = 'small' if m > 0 else 'tiny'
            sized = lambda p: not sizes or all(at_size(p, k) for k in win)
            if n >= 0.15 * iters and abs(m) > 1.0 and sized(leader):
                return '%s at %d (small\'s lead %+.2f dB)' % (leader, n, m)
            if n >= 0.5 * iters and (not sizes or len(win) == 3) and sized('tiny') \
                    and sized('small'):
                return '%s at %d (small\'s lead %+.2f dB)' % (leader, n, m)
        if common[-1] < iters - 100:
            return 'none before the courses end (%d)' % common[-1]
        m = lead(key, common[-3:])
        return '%s at the end (small\'s lead %+.2f dB)' % ('small' if m > 0 else 'tiny', m)

    def race():  # cn_race_step: a lead of small's counts only at its size
        waiting = False
        for i, n in enumerate(common):
            win = common[max(0, i - 2):i + 1]
            m = lead(key, win)
            sized = all(at_size('small', k) for k in win)
            say = '%s at %d (small\'s lead %+.2f dB%s)' % (
                'small' if m > 0 else 'tiny', n, m, ', after waiting' if waiting else '')
            if n < 0.15 * iters:
                continue
            if waiting:
                if sized and len(win) == 3:
                    return say
                continue
            if m < -1.0 or (m > 1.0 and sized):
                return say
            if n < 0.5 * iters:
                continue
            if m > 0 and not sized:
                waiting = True
                continue
            return say
        if common[-1] < iters - 100:
            return 'none before the courses end (%d)' % common[-1]
        m = lead(key, common[-3:])
        return '%s at the end (small\'s lead %+.2f dB)' % ('small' if m > 0 else 'tiny', m)
    print("  the race's verdict: %s" % race())
    print("  the race before sizes counted: %s" % replay(False))
    print("  at size: %s" % replay(True))
