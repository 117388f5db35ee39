/* Benchmark: one training step of the render (both networks, forward and backward) at a
 * preset's shapes with random rays through the Lego geometry, against the encoder's GEMM
 * (cn_sgemm) at the same matrix shapes. Prints medians of N runs and achieved GFLOP/s.
 *   bench_step [preset] [rays] [runs]                                                      */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "cn_gemm.h"
#include "cn_render.h"
#include "cn_synth.h"
#include "benchutil.h"

/* Multiply-adds of one forward pass of network `net` over P points. */
static double net_macs(const cnerf_info *T, unsigned net, double P)
{
    double macs = 0;
    const cnerf_net_info *N = &T->net[net];
    for (unsigned l = N->first_layer; l < (unsigned)N->first_layer + N->n_layers; l++)
        macs += (double)T->layer[l].n_in * T->layer[l].n_out;
    return macs * P;
}

int main(int argc, char **argv)
{
    const char *preset = argc > 1 ? argv[1] : "small";
    const size_t R = argc > 2 ? (size_t)atol(argv[2]) : 1024;
    const int runs = argc > 3 ? atoi(argv[3]) : 10;
    cnerf_info hdr;
    if (cn_preset_header(preset, &hdr)) {
        fprintf(stderr, "unknown preset %s\n", preset);
        return 2;
    }
    cn_model m;
    char err[256];
    cn_batch b;
    if (cn_model_init(&m, &hdr, 1, err, sizeof err) || cn_batch_init(&b, &m.topo, R)) {
        fprintf(stderr, "init failed\n");
        return 1;
    }
    cn_rng r = cn_rng_seed(3);
    for (size_t i = 0; i < R; i++) {
        /* cameras on a sphere of radius 4 looking at the origin, like Blender scenes */
        double th = 2 * M_PI * cn_rng_uniform(&r), ph = 0.3 + 0.9 * cn_rng_uniform(&r);
        float o[3] = {(float)(4 * cos(th) * cos(ph)), (float)(4 * sin(th) * cos(ph)),
                      (float)(4 * sin(ph))};
        float d[3];
        for (int a = 0; a < 3; a++)
            d[a] = -o[a] / 4.0f + (float)(cn_rng_uniform(&r) - 0.5) * 0.3f;
        float n = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        for (int a = 0; a < 3; a++) {
            b.o[3 * i + a] = o[a];
            b.d[3 * i + a] = d[a];
            b.vd[3 * i + a] = d[a] / n;
        }
    }
    float *dcol[2] = {malloc(sizeof(float) * R * 3), malloc(sizeof(float) * R * 3)};
    for (size_t i = 0; i < 3 * R; i++)
        dcol[0][i] = dcol[1][i] = 1e-3f;
    double *fw = malloc(sizeof(double) * runs), *bw = malloc(sizeof(double) * runs);
    for (int it = -1; it < runs; it++) { /* one warm-up */
        uint64_t seed = (uint64_t)it + 7;
        double t0 = bench_now();
        cn_render_forward(&m, &b, R, &seed);
        double t1 = bench_now();
        cn_render_backward(&m, &b, R, dcol);
        double t2 = bench_now();
        if (it >= 0) {
            fw[it] = t1 - t0;
            bw[it] = t2 - t1;
        }
    }
    const cnerf_info *T = &m.topo;
    /* Executed work counts the samples inside the scene bounds (the only ones that go
     * through a network); nominal work counts every sample. */
    const int two = T->n_nets > 1;
    double macs = net_macs(T, 0, (double)b.n_rows[0]) + (two ? net_macs(T, 1, (double)b.n_rows[1]) : 0);
    double nominal = net_macs(T, 0, (double)R * b.nc) + (two ? net_macs(T, 1, (double)R * b.ns) : 0);
    double flops = 2 * macs * 3; /* forward + backward (dX and dW) */
    double f = bench_median(fw, runs), bk = bench_median(bw, runs);
    printf("preset %s, %zu rays, %u+%u samples (%.1f%% inside the bounds): forward %.4f s, "
           "backward %.4f s, step %.4f s (median of %d), %.1f GFLOP/step executed "
           "(%.1f nominal), %.1f GFLOP/s\n",
           preset, R, T->n_coarse, T->n_fine, 100.0 * macs / nominal, f, bk, f + bk, runs,
           flops * 1e-9, 6 * nominal * 1e-9, flops * 1e-9 / (f + bk));
    /* sgemm at the largest trunk shape: P x W times W x W */
    const int P = (int)(R * b.ns), W = T->net[0].width;
    float *A = calloc((size_t)P * W, 4), *B = calloc((size_t)W * W, 4), *C = calloc((size_t)P * W, 4);
    double *gs = malloc(sizeof(double) * runs);
    for (int it = -1; it < runs; it++) {
        double t0 = bench_now();
        cn_sgemm(0, 1, (size_t)P, (size_t)W, (size_t)W, A, (size_t)W, B, (size_t)W, 0, C, (size_t)W);
        if (it >= 0)
            gs[it] = bench_now() - t0;
    }
    double g = bench_median(gs, runs);
    printf("sgemm (%s) %dx%dx%d: %.4f s, %.1f GFLOP/s; step at that rate would take %.4f s\n",
           cn_gemm_library(), P, W, W, g, 2.0 * P * W * W * 1e-9 / g, flops / (2.0 * P * W * W / g));
    return 0;
}
