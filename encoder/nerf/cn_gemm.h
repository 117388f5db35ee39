/* The encoder's matrix products, in one place: row-major single precision
 *   C[M x N] = op(A)[M x K] · op(B)[K x N] + beta · C
 * with op(X) = X, or its transpose when trans_x is non-zero. The library is chosen when cnerf
 * is configured (CMake option CNERF_GEMM: oneDNN's dnnl_sgemm by default, or OpenBLAS's
 * cblas_sgemm); docs/training.md has the measurements behind the choice. */
#ifndef CN_GEMM_H
#define CN_GEMM_H

#include <stddef.h>

void cn_sgemm(int trans_a, int trans_b, size_t M, size_t N, size_t K, const float *A, size_t lda,
              const float *B, size_t ldb, float beta, float *C, size_t ldc);

/* Threads the products may use (OpenMP's count for oneDNN, OpenBLAS's own pool otherwise). */
void cn_gemm_set_threads(int n);

/* "onednn" or "openblas". */
const char *cn_gemm_library(void);

#endif
