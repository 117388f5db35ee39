/* Benchmark: the trainer's three matrix products per layer at the trainer's real shapes,
 * through one GEMM library chosen when this file is compiled:
 *   -DGEMM_OPENBLAS  cblas_sgemm of OpenBLAS (what the encoder links)
 *   -DGEMM_BLIS      cblas_sgemm of BLIS (libblis-dev, OpenMP build)
 *   -DGEMM_DNNL      dnnl_sgemm of oneDNN (libdnnl-dev)
 * tests/CMakeLists.txt builds one executable per library found: bench_gemm_openblas,
 * bench_gemm_blis, bench_gemm_dnnl; scripts/bench_gemm.sh runs them side by side.
 *   bench_gemm_X [rows] [runs] [chunk]
 * For rows P (samples in a batch) and each layer shape n_in -> n_out of preset small's
 * networks, it times (median of runs, threads from OMP_NUM_THREADS / the library default):
 *   fwd  Y[P x n_out]  = X[P x n_in] W^T          (beta 0)
 *   dW   dW[n_out x n_in] += dY^T X               (beta 1, reduction over P)
 *   dX   dX[P x n_in]  = dY W                     (beta 0)
 * With `chunk` (default: rows), each product is made as ceil(rows / chunk) calls on
 * consecutive blocks of `chunk` rows (dW accumulating), as a trainer that splits its batch
 * would. Prints one CSV line per product: library,product,P,chunk,n_in,n_out,seconds,GFLOP/s,
 * then the total of one network's products (first layer, three trunk layers, the skip layer,
 * the view branch). */
#include <stdio.h>
#include <stdlib.h>

#include "benchutil.h"

#if defined(GEMM_OPENBLAS) || defined(GEMM_BLIS)
#include <cblas.h>
#if defined(GEMM_OPENBLAS)
#define LIB "openblas"
#else
#define LIB "blis"
#endif
/* Row-major C = alpha op(A) op(B) + beta C with op(A) M x K, op(B) K x N. */
static void gemm(int ta, int tb, int M, int N, int K, const float *A, int lda, const float *B,
                 int ldb, float beta, float *C, int ldc)
{
    cblas_sgemm(CblasRowMajor, ta ? CblasTrans : CblasNoTrans, tb ? CblasTrans : CblasNoTrans,
                M, N, K, 1.0f, A, lda, B, ldb, beta, C, ldc);
}
#elif defined(GEMM_DNNL)
#include <oneapi/dnnl/dnnl.h>
#define LIB "onednn"
static void gemm(int ta, int tb, int M, int N, int K, const float *A, int lda, const float *B,
                 int ldb, float beta, float *C, int ldc)
{
    if (dnnl_sgemm(ta ? 'T' : 'N', tb ? 'T' : 'N', M, N, K, 1.0f, A, lda, B, ldb, beta, C, ldc) !=
        dnnl_success) {
        fprintf(stderr, "dnnl_sgemm failed\n");
        exit(1);
    }
}
#else
#error "define GEMM_OPENBLAS, GEMM_BLIS or GEMM_DNNL"
#endif

enum { FWD, DW, DX };
static const char *const names[] = {"fwd", "dW", "dX"};

static double time_product(int what, int P, int chunk, int n_in, int n_out, int runs, float *X,
                           float *W, float *Y)
{
    double *t = malloc(sizeof(double) * (size_t)runs), med;
    for (int r = -1; r < runs; r++) { /* one warm-up */
        double t0 = bench_now();
        for (int p0 = 0; p0 < P; p0 += chunk) {
            const int n = P - p0 < chunk ? P - p0 : chunk;
            float *x = X + (size_t)p0 * n_in, *y = Y + (size_t)p0 * n_out;
            if (what == FWD)
                gemm(0, 1, n, n_out, n_in, x, n_in, W, n_in, 0.0f, y, n_out);
            else if (what == DW)
                gemm(1, 0, n_out, n_in, n, y, n_out, x, n_in, 1.0f, W, n_in);
            else
                gemm(0, 0, n, n_in, n_out, y, n_out, W, n_in, 0.0f, x, n_in);
        }
        if (r >= 0)
            t[r] = bench_now() - t0;
    }
    med = bench_median(t, runs);
    free(t);
    return med;
}

int main(int argc, char **argv)
{
    const int P = argc > 1 ? atoi(argv[1]) : 65536;
    const int runs = argc > 2 ? atoi(argv[2]) : 9;
    const int chunk = argc > 3 ? atoi(argv[3]) : P;
    if (P < 1 || runs < 1 || chunk < 1) {
        fprintf(stderr, "usage: %s [rows >= 1] [runs >= 1] [chunk >= 1]\n", argv[0]);
        return 2;
    }
    /* Preset small (width 128, position encoding 63, direction encoding 27): the first
     * layer, a trunk layer, the skip layer and the view branch. `count` is how many such
     * layers one network has. */
    static const struct {
        int n_in, n_out, count;
    } shapes[] = {{63, 128, 1}, {128, 128, 3}, {191, 128, 1}, {155, 64, 1}};
    const size_t big = (size_t)P * 192;
    float *X = malloc(sizeof(float) * big), *Y = malloc(sizeof(float) * big);
    float *W = malloc(sizeof(float) * 192 * 192);
    if (!X || !Y || !W)
        return 1;
    for (size_t i = 0; i < big; i++) {
        X[i] = (float)((i * 2654435761u) % 1000) * 1e-3f - 0.5f;
        Y[i] = (float)((i * 40503u) % 1000) * 1e-3f - 0.5f;
    }
    for (int i = 0; i < 192 * 192; i++)
        W[i] = (float)((i * 7919) % 1000) * 1e-4f;
    double total = 0, flops = 0;
    printf("library,product,rows,chunk,n_in,n_out,seconds,gflops\n");
    for (size_t s = 0; s < sizeof shapes / sizeof shapes[0]; s++)
        for (int what = FWD; what <= DX; what++) {
            const int n_in = shapes[s].n_in, n_out = shapes[s].n_out;
            const double sec = time_product(what, P, chunk, n_in, n_out, runs, X, W, Y);
            const double f = 2.0 * P * n_in * n_out;
            printf("%s,%s,%d,%d,%d,%d,%.5f,%.1f\n", LIB, names[what], P, chunk, n_in, n_out, sec,
                   f * 1e-9 / sec);
            total += sec * shapes[s].count;
            flops += f * shapes[s].count;
        }
    printf("%s,network,%d,%d,,,%.5f,%.1f\n", LIB, P, chunk, total, flops * 1e-9 / total);
    free(X);
    free(Y);
    free(W);
    return 0;
}
