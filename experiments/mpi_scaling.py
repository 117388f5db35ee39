#!/usr/bin/env python3
"""A model of data-parallel training time on a cluster (docs/training.md, "Several processes").

    experiments/mpi_scaling.py SECS_PER_IT BATCH CORES PARAMS

SECS_PER_IT: measured seconds per iteration of one process with BATCH rays per iteration on
CORES cores; PARAMS: the model's parameters (each summed as a 16-byte exact integer).

Assumptions, stated: compute scales linearly with rays and cores (an upper bound on speed);
a rank gets whole chunks of 128 rays (CN_CHUNK_RAYS), so a batch of R rays keeps at most
R / 128 ranks busy and the slowest rank sets the step; the sums are ring allreduces,
2 (N - 1) / N of the bytes over each link and 2 (N - 1) latencies per sum, three sums per
step (the errors, then the coarse and the fine network's gradients, which together are every
parameter once); every rank holds the whole dataset.
"""
import math
import sys

CHUNK = 128
NETS = {"10 GbE": (1.25e9, 50e-6), "100 Gb InfiniBand": (12.5e9, 2e-6)}


def step(secs_1core_ray, rays, nodes, cores, params, bw, lat):
    chunks = math.ceil(rays / CHUNK)
    busiest = math.ceil(chunks / nodes) * CHUNK  # rays of the busiest rank
    compute = secs_1core_ray * min(busiest, rays) / cores
    if nodes == 1:
        return compute, 0.0
    comm = 2 * (nodes - 1) / nodes * 16 * params / bw + 3 * 2 * (nodes - 1) * lat
    return compute, comm


def main():
    if len(sys.argv) != 5:
        sys.exit(__doc__)
    secs, batch, cores, params = float(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
    per_core_ray = secs * cores / batch  # seconds of one core per ray
    rays, node_cores, iters = 4096, 32, 200000
    print(f"measured: {secs:.3f} s/it for {batch} rays on {cores} cores = {per_core_ray * 1e3:.3f} "
          f"core-ms per ray; {params} parameters, {16 * params / 1e6:.1f} MB summed per step")
    print(f"predicted: {rays} rays per iteration, {iters} iterations, nodes of {node_cores} cores\n")
    print("| network | nodes | compute (s/it) | sums (s/it) | s/it | wall time | speed-up |")
    print("|---|---|---|---|---|---|---|")
    for name, (bw, lat) in NETS.items():
        base = None
        for nodes in (1, 8, 32, 128):
            c, m = step(per_core_ray, rays, nodes, node_cores, params, bw, lat)
            t = c + m
            base = base or t
            days = t * iters / 86400
            print(f"| {name} | {nodes} | {c:.3f} | {m:.3f} | {t:.3f} | {days:.1f} days | {base / t:.1f}x |")


if __name__ == "__main__":
    main()
