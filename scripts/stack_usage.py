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
           "cnerf_net_has_color", "cnerf_camera_look_at", "cnerf_open_packed"]


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


def elf_frames(elf, names, objdump="arm-none-eabi-objdump"):
    """Frames and calls of functions that have no call-graph file (libgcc's integer helpers,
    which Armv6-M code calls), from the linked ELF's disassembly: a function's frame is the
    sum of all its pushes and stack reservations (a bound whatever path it takes), its
    calls every BL and every branch to another function's start (tail calls). Follows the
    calls it finds. Returns frames, edges, problems."""
    import subprocess
    text = subprocess.run([objdump, "-d", elf], capture_output=True, text=True,
                          check=True).stdout
    body, cur, at = {}, None, {}
    for line in text.splitlines():
        m = re.match(r"^([0-9a-f]+) <([^>]+)>:$", line)
        if m:
            cur = m.group(2)
            body[cur] = []
            at[int(m.group(1), 16)] = cur
        elif cur and "\t" in line:
            body[cur].append(line.split("\t", 2)[-1])
    # an alias (__aeabi_uidiv of __udivsi3) shares its function's address and body
    nm = subprocess.run([objdump.replace("objdump", "nm"), elf], capture_output=True,
                        text=True, check=True).stdout
    for line in nm.splitlines():
        f = line.split()
        if len(f) == 3 and f[2] not in body and int(f[0], 16) & ~1 in at:
            body[f[2]] = body[at[int(f[0], 16) & ~1]]
    frames, edges, problems, todo = {}, {}, [], list(names)
    while todo:
        fn = todo.pop()
        if fn in frames:
            continue
        if fn not in body:
            problems.append(f"{fn}: not in {os.path.basename(elf)}")
            frames[fn] = 0
            continue
        size = 0
        for ins in body[fn]:
            m = re.match(r"(push|stmdb|vpush)(\.w)?\s+(sp!,\s*)?\{([^}]*)\}", ins)
            if m:
                size += 4 * len(m.group(4).split(","))
                continue
            m = re.match(r"sub(s|\.w)?\s+sp,\s*(sp,\s*)?#(\d+)", ins)
            if m:
                size += int(m.group(3))
                continue
            if re.match(r"(sub|mov|add)\S*\s+sp,\s*(sp,\s*)?r", ins) or ins.startswith("blx\tr"):
                problems.append(f"{fn}: a stack or call it cannot bound ({ins.strip()})")
            m = re.match(r"(bl|b|b\.n|b\.w)\s+[0-9a-f]+ <([^>+]+)>", ins)
            if m and m.group(2) != fn:
                edges.setdefault(fn, set()).add(m.group(2))
                todo.append(m.group(2))
        frames[fn] = size
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
