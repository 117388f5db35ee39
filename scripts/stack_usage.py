#!/usr/bin/env python3
"""Worst-case stack depth of the decoder's API entry points, from GCC's call-graph files.

Compile with -fcallgraph-info=su (the Cortex-M build does); then
    scripts/stack_usage.py BUILD_DIR
prints each public entry point's deepest call chain in bytes and exits non-zero if a
frame is dynamic (alloca/VLA), a call is indirect, or the graph has a cycle (recursion):
then no bound exists and the build must not claim one.
"""
import glob
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ENTRIES = ["cnerf_peek", "cnerf_open", "cnerf_workspace_size", "cnerf_expand_topology",
           "cnerf_latent", "cnerf_crc32", "cnerf_status_str",
           "cnerf_render_scratch_size", "cnerf_render_defaults", "cnerf_render_tile",
           "cnerf_net_has_color"]


def load(build_dir, check_sources=True):
    frames, edges, problems, where = {}, {}, [], {}
    files = glob.glob(os.path.join(build_dir, "**", "*.ci"), recursive=True)
    for path in files:
        if "cnerf_dec.dir" not in path:
            continue
        # A call-graph file whose source no longer exists is left over in a reused build
        # directory: not part of the decoder.
        source = path.split("cnerf_dec.dir" + os.sep, 1)[1][:-len(".ci")]
        if check_sources and not os.path.exists(os.path.join(ROOT, source)):
            continue
        text = open(path).read()
        for m in re.finditer(r'node: \{ title: "([^"]+)" label: "([^"]+)"', text):
            title, label = m.group(1), m.group(2)
            s = re.search(r"\\n(\d+) bytes \(([^)]+)\)", label)
            if not s:
                continue  # external declaration
            if title in where and where[title] != path:
                # Two call-graph files define one external function: one of them is left
                # over from a source file that no longer exists (build from a clean tree).
                problems.append(f"{title}: defined in both {where[title]} and {path}")
            where[title] = path
            frames[title] = int(s.group(1))
            if "dynamic" in s.group(2):
                problems.append(f"{title}: dynamic stack frame ({s.group(2)})")
        for m in re.finditer(r'edge: \{ sourcename: "([^"]+)" targetname: "([^"]+)"', text):
            src, dst = m.group(1), m.group(2)
            if dst == "__indirect_call":
                problems.append(f"{src}: indirect call")
            edges.setdefault(src, set()).add(dst)
    return frames, edges, problems


def deepest(fn, frames, edges, stack, memo):
    if fn in memo:
        return memo[fn]
    if fn in stack:
        raise RecursionError(" -> ".join(stack + [fn]))
    best, best_path = 0, []
    for callee in edges.get(fn, ()):
        if callee not in frames:
            raise KeyError(f"{fn} calls {callee}, which the decoder does not define")
        d, p = deepest(callee, frames, edges, stack + [fn], memo)
        if d > best:
            best, best_path = d, p
    memo[fn] = (frames[fn] + best, [fn] + best_path)
    return memo[fn]


def main():
    build_dir = sys.argv[1] if len(sys.argv) > 1 else "build-m4"
    frames, edges, problems = load(build_dir)
    if not frames:
        sys.exit(f"stack_usage: no decoder .ci files under {build_dir} (-fcallgraph-info=su?)")
    memo, worst = {}, 0
    try:
        for e in ENTRIES:
            if e not in frames:
                continue
            d, path = deepest(e, frames, edges, [], memo)
            worst = max(worst, d)
            chain = " -> ".join(p.split(":")[-1] for p in path)
            print(f"stack {e:24s} {d:5d} bytes  ({chain})")
    except (RecursionError, KeyError) as exc:
        problems.append(str(exc))
    for p in problems:
        print("stack_usage: no bound:", p, file=sys.stderr)
    if problems:
        sys.exit(1)
    print(f"stack worst case over the API: {worst} bytes")


if __name__ == "__main__":
    main()
