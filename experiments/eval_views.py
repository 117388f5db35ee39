"""Per-view PSNRs from `cnerf eval` logs, and the difference of two runs over their test
views with its standard error; shared by experiments/scene_suite.sh (--views, --table
--views) and experiments/tiny_warmup.sh."""
import math
import re

VIEW = re.compile(r'^  (\S+) +psnr +([0-9.]+) dB')


def eval_views(path):
    """The (view, PSNR as printed) pairs of an eval log, in its order."""
    with open(path) as f:
        return [m.groups() for m in map(VIEW.match, f) if m]


def paired(a, b):
    """For two runs' {view: PSNR}: the mean over the views of b's PSNR minus a's (the
    difference of their means), its standard error and the number of views; None unless
    both have the same views, two or more."""
    if not a or not b or set(a) != set(b) or len(a) < 2:
        return None
    d = [b[k] - a[k] for k in a]
    m = sum(d) / len(d)
    return m, math.sqrt(sum((x - m) ** 2 for x in d) / (len(d) - 1) / len(d)), len(d)
