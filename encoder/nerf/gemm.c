/* cn_sgemm through the library chosen at configure time (CNERF_GEMM). */
#include <stdio.h>
#include <stdlib.h>

#include <omp.h>

#include "cn_gemm.h"

#if defined(CNERF_GEMM_ONEDNN)
#include <oneapi/dnnl/dnnl.h>

void cn_sgemm(int trans_a, int trans_b, size_t M, size_t N, size_t K, const float *A, size_t lda,
              const float *B, size_t ldb, float beta, float *C, size_t ldc)
{
    if (M == 0 || N == 0)
        return;
    /* Small products run on one thread: oneDNN's threads meet at barriers inside every call,
     * and on a loaded machine a descheduled thread stalls the others far longer than the
     * product takes (a gradient test of tiny layers took minutes instead of a second). */
    const int small = (double)M * N * K < (double)(1 << 20), threads = omp_get_max_threads();
    if (small && threads > 1)
        omp_set_num_threads(1);
    const dnnl_status_t st =
        dnnl_sgemm(trans_a ? 'T' : 'N', trans_b ? 'T' : 'N', (dnnl_dim_t)M, (dnnl_dim_t)N,
                   (dnnl_dim_t)K, 1.0f, A, (dnnl_dim_t)lda, B, (dnnl_dim_t)ldb, beta, C,
                   (dnnl_dim_t)ldc);
    if (small && threads > 1)
        omp_set_num_threads(threads);
    if (st != dnnl_success) { /* only bad arguments fail: a bug, not an input error */
        fprintf(stderr, "cnerf: dnnl_sgemm(%zu, %zu, %zu) failed with status %d\n", M, N, K,
                (int)st);
        abort();
    }
}

void cn_gemm_set_threads(int n) { omp_set_num_threads(n); }

const char *cn_gemm_library(void) { return "onednn"; }

#else
#include <cblas.h>

void cn_sgemm(int trans_a, int trans_b, size_t M, size_t N, size_t K, const float *A, size_t lda,
              const float *B, size_t ldb, float beta, float *C, size_t ldc)
{
    if (M == 0 || N == 0)
        return;
    cblas_sgemm(CblasRowMajor, trans_a ? CblasTrans : CblasNoTrans,
                trans_b ? CblasTrans : CblasNoTrans, (int)M, (int)N, (int)K, 1.0f, A, (int)lda, B,
                (int)ldb, beta, C, (int)ldc);
}

void cn_gemm_set_threads(int n)
{
    omp_set_num_threads(n);
    openblas_set_num_threads(n);
}

const char *cn_gemm_library(void) { return "openblas"; }
#endif
