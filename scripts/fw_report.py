#!/usr/bin/env python3
"""The report of one firmware run (scripts/firmware.sh runs it after QEMU): every job's tile
against the host's render of it (tests/xarch/render_tile.c, built as HOST) and against the MD5
the job expects, then what the firmware costs on the target: flash, RAM, the worst-case stack
(scripts/stack_usage.py over GCC's call graphs) and instructions per ray (QEMU -icount shift=0).

  fw_report.py ROOT BDIR ELF OUT JOBS HOST BUILD_TYPE CORE KERNEL_SET TIMER2 MODE

MODE tile (firmware.sh STREAM CAMERA TILE ...): one job, the full report, as firmware.sh
documents it. MODE jobs (firmware.sh --jobs): the memory and stack of the image, then one
line per job.
FW_COST_TOLERANCE (environment): the cost model must be within it of QEMU's count. Exit
status 0 when every check passes."""
import glob, hashlib, os, re, shutil, subprocess, sys, tempfile

root, bdir, elf, out, jobs_path, host, btype, core, kset, timer2, mode = sys.argv[1:]
sys.path.insert(0, os.path.join(root, "scripts"))
import stack_usage as su  # noqa: E402

n = lambda v: f"{v:,}"
status = 0


def problem(msg):
    global status
    print(f"firmware.sh: {msg}", file=sys.stderr)
    status = 1


# ---- the jobs and the firmware's lines ----
jobs = []
for line in open(jobs_path):
    w = line.split()
    if w and not w[0].startswith("#"):
        jobs.append(dict(name=w[0], expect=w[1], stream=w[2], scene=w[3], camera=w[4],
                         camname=w[5], args=w[6:]))
fw, fw_jobs = {}, []
for line in open(out):
    f = line.split()
    if len(f) == 2 and f[0] == "md5" and fw_jobs:
        fw_jobs[-1]["md5"] = f[1]
    elif len(f) > 2 and f[0] == "fw" and len(f) % 2 == 0:
        d = {f[i]: int(f[i + 1]) for i in range(2, len(f), 2)}
        if f[1] == "job":
            fw_jobs.append({"job": d})
        elif f[1] in ("render", "ticks") and fw_jobs:
            fw_jobs[-1][f[1]] = d
        else:
            fw[f[1]] = d
if len(fw_jobs) != len(jobs) or any("md5" not in j for j in fw_jobs):
    sys.stdout.write(open(out).read())
    problem(f"the firmware reported {len(fw_jobs)} of {len(jobs)} jobs")
    sys.exit(1)
single = mode == "tile"

# ---- each job's tile on the host ----
with tempfile.TemporaryDirectory() as tmp:
    for i, (job, fj) in enumerate(zip(jobs, fw_jobs)):
        cam = os.path.join(tmp, "cam")
        with open(job["camera"]) as f:
            lines = [l for l in f if l.split()]
        pick = [l for l in lines if job["camname"] == "-" or l.split()[-1] == job["camname"]]
        with open(cam, "w") as f:
            f.write(" ".join(pick[0].split()[:18]) + "\n" if pick else "")
        env = dict(os.environ, CNERF_SCENE=job["scene"], CNERF_CORE=core, CNERF_CORE_SET=kset,
                   CNERF_WS_FAST=os.environ.get("FW_FAST", "0"))
        r = subprocess.run([host, job["stream"], cam] + job["args"], env=env, capture_output=True)
        if r.returncode != 0:
            sys.stderr.write(r.stderr.decode())
            problem(f"{job['name']}: the host render failed")
            continue
        fj["host_md5"] = hashlib.md5(r.stdout).hexdigest()
        fj["host_cost"] = r.stderr.decode()
        if single:
            print(f"firmware md5 {fj['md5']}")
            print(f"host     md5 {fj['host_md5']}")
        if fj["md5"] != fj["host_md5"]:
            problem(f"MISMATCH: {job['name']}: the firmware's tile {fj['md5']} differs from the "
                    f"host's {fj['host_md5']}")
        if job["expect"] != "-":
            if single:
                print(f"expected md5 {job['expect']}")
            if fj["md5"] != job["expect"]:
                problem(f"MISMATCH: {job['name']}: the tile's MD5 {fj['md5']} is not the "
                        f"expected {job['expect']}")

# ---- memory ----
sec = {}
for line in subprocess.run(["arm-none-eabi-size", "-A", elf], capture_output=True, text=True,
                           check=True).stdout.splitlines():
    f = line.split()
    if len(f) == 3 and f[0].startswith("."):
        sec[f[0]] = int(f[1])
sym = {}
for line in subprocess.run(["arm-none-eabi-nm", "-S", "-t", "d", elf], capture_output=True,
                           text=True, check=True).stdout.splitlines():
    f = line.split()
    if len(f) == 4:
        sym[f[3]] = int(f[1])
code = sec.get(".vectors", 0) + sec.get(".text", 0) + sec.get(".ARM.exidx", 0)
stream = sum(v for k, v in sym.items() if re.fullmatch(r"cnerf_fw_stream(_\d+)?", k))
packed = sum(v for k, v in sym.items() if re.fullmatch(r"cnerf_fw_image\d+", k))
stream += packed
consts = sec.get(".rodata", 0) - stream
tables = sum(sym.get(t, 0) for t in ("cn_sin_q30", "cn_exp2_q30", "cn_sigmoid_q30"))
data = sec.get(".data", 0)
flash = code + sec.get(".rodata", 0) + data
bss = sec.get(".bss", 0)
stack_size = sec.get(".stack", 0)
named = {k: sym.get(k, 0) for k in ("ws", "scratch", "dec", "tile")}
print(f"== cost on the target: {core}, {btype}, decoder + firmware, {os.path.basename(elf)}"
      f"{'' if single else f', {len(jobs)} jobs'} ==")
print(f"flash {n(flash)} bytes: code {n(code)} (vector table {sec.get('.vectors', 0)}), "
      f"constants {n(consts)} (decoder sin/exp2/sigmoid tables {n(tables)}), "
      f"embedded {'packed image' if packed else 'stream'}{'' if single else 's'} {n(stream)}"
      f"{' (read in place: workspace, latents and grid in flash)' if packed else ''}, "
      f".data image {n(data)}")
print(f"RAM   {n(data + bss + stack_size)} bytes: .data {n(data)} + .bss {n(bss)} (workspace "
      f"{n(named['ws'])}, render scratch {n(named['scratch'])}, cnerf_decoder {n(named['dec'])}, "
      f"tile buffer {n(named['tile'])}, other {n(bss - sum(named.values()))}) + stack "
      f"{n(stack_size)} reserved")

# ---- worst-case stack: the decoder's call graph and the firmware's, both from GCC's
# -fcallgraph-info=su, through scripts/stack_usage.py. Its load() reads only directories
# named cnerf_dec.dir, so the firmware's .ci files are staged under that name. ----
frames, edges, problems = su.load(bdir)
with tempfile.TemporaryDirectory() as tmp:
    stage = os.path.join(tmp, "cnerf_dec.dir")
    os.mkdir(stage)
    for p in glob.glob(os.path.join(bdir, "platform", "cortex-m", "CMakeFiles", "cnerf_fw.dir",
                                    "*.ci")):
        shutil.copy(p, stage)
    f2, e2, p2 = su.load(tmp, check_sources=False)
frames.update(f2)
for k, v in e2.items():
    edges.setdefault(k, set()).update(v)
problems += p2
# Functions GCC's call graphs do not cover (libgcc's integer helpers on Armv6-M): their
# frames and calls from the ELF's disassembly.
missing = {c for k in edges for c in edges[k] if c not in frames}
if missing:
    f3, e3, p3 = su.elf_frames(elf, sorted(missing))
    frames.update(f3)
    for k, v in e3.items():
        edges.setdefault(k, set()).update(v)
    problems += p3
# Fault_Handler is naked assembly that branches to fw_fault_report: an edge GCC cannot see.
edges.setdefault("Fault_Handler", set()).add("fw_fault_report")
# An exception frame + alignment: the basic frame on the M4 (soft float, FPU off); on the M55
# CP10/CP11 are on, and once FP or MVE code has run the frame is the extended one (+ S0-S15,
# FPSCR, VPR).
EXC = (26 * 4 if core == "Cortex-M55" else 32) + 4
try:
    memo = {}
    thread, path = su.deepest("Reset_Handler", frames, edges, [], memo)
    tick, _ = su.deepest("SysTick_Handler", frames, edges, [], memo)
    fault, fpath = su.deepest("Fault_Handler", frames, edges, [], memo)
except (RecursionError, KeyError) as exc:
    problems.append(str(exc))
if problems:
    for p in problems:
        print("firmware.sh: no stack bound:", p, file=sys.stderr)
    sys.exit(1)
worst = thread + EXC + tick + EXC + fault
hw = fw["stack"]["high_water"]
chain = " -> ".join(p.split(":")[-1] for p in path)
print(f"stack worst case {n(worst)} bytes of {n(stack_size)} reserved = thread {thread} "
      f"({chain}) + SysTick {EXC}+{tick} + fault {EXC}+{fault}; measured high-water {hw}")
print(f"RAM needed with the stack's worst case instead of the reservation: "
      f"{n(data + bss + worst)} bytes")
if worst > stack_size:
    problem(f"the stack's worst case {worst} exceeds the {stack_size} bytes reserved (FW_STACK)")
if hw > thread + EXC + tick:
    problem(f"the measured stack {hw} exceeds the static bound: the call graph is incomplete")

# ---- instructions: 10^9 / (SysTick clock) per SysTick tick under -icount shift=0 (1 ns per
# instruction; 40 at 25 MHz, 31.25 at 32 MHz), valid only if the firmware's calibration loop
# says so (+-1 tick) and the SysTick's wrap counting agrees with the second counter's 32-bit
# count on the same clock over the whole run. ----
IPT = 1e9 / fw["clock"]["cpu_hz"]
cal, cross = fw["calib"], fw["crosscheck"]
cross2 = next(v for k, v in cross.items() if k != "systick")
ok_cal = abs(cal["ticks"] * IPT - cal["insns"]) <= 2 * IPT
# The second counter is 32 bits wide: a batch that runs longer than 2^32 ticks (172 s of
# virtual time at 25 MHz) wraps it, so the two agree modulo 2^32. A miscounted SysTick wrap
# shifts the count by a multiple of 2^24 ticks, which this still sees unless it is a multiple
# of 2^32.
ok_cross = min((cross["systick"] - cross2) % 2**32, (cross2 - cross["systick"]) % 2**32) <= 2
print(f"instructions (QEMU -icount shift=0, SysTick ticks x {IPT:g}; each figure +-1 tick): "
      f"calibration loop {n(cal['insns'])} = {n(cal['ticks'])} ticks "
      f"({'ok' if ok_cal else 'FAILED'}), SysTick vs {timer2} over the run "
      f"{n(cross['systick'])} / {n(cross2)} ticks ({'ok' if ok_cross else 'FAILED'})")
if not (ok_cal and ok_cross):
    problem("the instruction counts are not valid (is this QEMU 7.2 with -icount shift=0?); "
            "not reported")
    sys.exit(1)
tol = os.environ.get("FW_COST_TOLERANCE")
for job, fj in zip(jobs, fw_jobs):
    r, ticks = fj["render"], fj["ticks"]
    ins = {k: round(v * IPT) for k, v in ticks.items()}
    rays = r["w"] * r["h"]
    per_ray = round(ins["render"] / rays)
    # The host's count of the same work, with this core's forms (tests/xarch/render_tile.c,
    # cnerf_open_as), must be the firmware's; the cost model's instructions beside QEMU's.
    text = fj.get("host_cost", "")
    hwork = re.search(r"host work of the tile: (.*)", text)
    model = re.search(r"cost model [^:]*: (\d+) instructions", text)
    counted_by = "the firmware"
    if hwork:
        h = dict(zip(hwork.group(1).split()[0::2], map(int, hwork.group(1).split()[1::2])))
        if "evals" in r:
            fwork = dict(r, rays=rays)
            diff = [k for k, v in h.items() if fwork.get(k) != v]
            if diff:
                problem(f"{job['name']}: the host's count of the {core}'s work differs from "
                        f"the firmware's in {', '.join(diff)}")
        else:  # FW_WORK=0 or first: the host's count (the same, where both count)
            r = dict(r, **{k: v for k, v in h.items() if k != "rays"})
            counted_by = "the host"
    cost = ""
    if model and ins["render"]:
        est = int(model.group(1))
        err = est / ins["render"] - 1
        cost = f"cost model: {n(est)} instructions for the tile, QEMU {n(ins['render'])} " \
               f"({100 * err:+.1f}%)"
        # (the model is a tile's, fitted on tiles: on one ray, an empty one, its per-tile
        # constant is most of the count; tests/firmware/vectors.sh's single rays are checked
        # for their pixel only)
        if tol and rays > 1 and abs(err) > float(tol):
            problem(f"{job['name']}: the cost model is {100 * err:+.1f}% off, beyond "
                    f"{100 * float(tol):.0f}% (FW_COST_TOLERANCE)")
    work = (f"rays {rays} evals {r['evals']} in_bounds {r['in_bounds']} macs {r['macs']} "
            f"list_macs {r['list_macs']} list_nz {r['list_nz']} samples {r['samples']} "
            f"layer_values {r['layer_values']} exact_rescales {r['exact_rescales']} "
            f"wide_macs {r['wide_macs']} s8_macs {r['s8_macs']} contract {r['contract']} ndc {r['ndc']} "
            f"in_pos {r['in_pos']} samples_per_ray {r['samples_per_ray']} "
            f"instructions {ins['render']}") if "evals" in r else ""
    if not single:
        print(f"{job['name']}: {fj['md5']}, {n(per_ray)} instructions per ray"
              f"{'; ' + cost if cost else ''}")
        if work:
            print(f"  work of the tile: {work}")
        continue
    print(f"  cnerf_peek {n(ins['peek'])}, cnerf_open {n(ins['open'])}, md5 of the tile "
          f"{n(ins['md5'])}")
    print(f"  cnerf_render_tile {n(ins['render'])} for {rays} rays ({r['w']}x{r['h']} at "
          f"{r['x0']},{r['y0']}; {r['n_coarse']} coarse + {r['n_fine']} fine samples, t_stop "
          f"{r['t_stop']}): {n(per_ray)} instructions per ray, per-tile set-up included")
    if "evals" not in r:  # FW_WORK=0
        if cost:
            print("  " + cost)
        continue
    print(f"  work of the tile: {work}")
    if counted_by == "the host":
        print("  (the work counted on the host, with this core's forms: FW_WORK)")
    if cost:
        print("  " + cost)
    grid = f"{r['grid']}^3 grid" if r["grid"] else "no grid"
    use = "ignored (CNERF_RENDER_NO_SKIP)" if r["flags"] & 1 else "used"
    print(f"  network evaluations per ray: {r['evals'] / rays:.2f} ({r['in_bounds'] / rays:.2f} "
          f"samples inside the bounds); {grid}, {use}")
    if r["macs"]:
        print(f"  network multiply-accumulates per ray: {n(round(r['macs'] / rays))}; "
              f"instructions per MAC: {ins['render'] / r['macs']:.2f} (all of "
              f"cnerf_render_tile over the MACs done)")
        print(f"  of them in layers summed from lists of their non-zero latents: "
              f"{n(round(r['list_macs'] / rays))}, which multiplied {n(round(r['list_nz'] / rays))}")
sys.exit(status)
