/*
 * Sums whose result does not depend on the order of the terms: each term is rounded once to
 * a fixed-point integer (units of 2^-64) and the integers are added exactly in 128
 * bits. However the terms are split among threads (or processes) and in whatever order
 * their partial sums meet, the total is the same integer, so the float read back from it is
 * the same to the bit. The trainer sums its gradients over rays this way (docs/training.md,
 * "Reproducibility").
 *
 * Terms are rounded toward zero to a multiple of 2^-64; a term whose magnitude is over 2^48
 * (or infinite) is clamped to +-2^48, so that 2^14 terms of that size still fit; NaN adds
 * nothing. Gradients and rates are many orders of magnitude inside both bounds.
 */
#ifndef CNERF_ENC_XSUM_H
#define CNERF_ENC_XSUM_H

#include <stddef.h>

#if !defined(__SIZEOF_INT128__)
#error "cnerf's encoder needs a compiler with 128-bit integers (GCC or Clang on a 64-bit target)"
#endif

typedef __int128 cn_xsum;

/* The term v as a fixed-point integer (see above). */
cn_xsum cn_xsum_of(double v);
/* The sum as a double (rounded once). */
double cn_xsum_value(cn_xsum s);

/* a + b (wrapping, never undefined). */
static inline cn_xsum cn_xsum_plus(cn_xsum a, cn_xsum b)
{
    return (cn_xsum)((unsigned __int128)a + (unsigned __int128)b);
}

/* acc[i] += v[i] for i < n, each term rounded as cn_xsum_of. */
void cn_xsum_add_f(cn_xsum *acc, const float *v, size_t n);
/* out[i] += (float)value(acc[i]) for i < n. */
void cn_xsum_put_f(float *out, const cn_xsum *acc, size_t n);

/* The processes that share a training's batches (docs/training.md, "Several processes"):
 * this one is rank `rank` of `size`, and allsum replaces v[0..n) on every rank by its sum
 * over all ranks, which is exact and so the same on every rank whatever the order. Every
 * rank makes the same calls in the same order. Returns 0, or -1 when the sum failed. A
 * NULL share, or size 1, is one process. */
typedef struct cn_share {
    int rank, size;
    int (*allsum)(void *ctx, cn_xsum *v, size_t n);
    void *ctx;
    /* This rank's vote to stop after the step (a signal's number, 0: go on), summed with the
     * step's first sum so that every rank learns of any rank's vote at the same step; NULL:
     * none. */
    int (*vote)(void *ctx);
} cn_share;

/* v summed over the share's ranks (nothing to do without one); 0 or -1. */
static inline int cn_share_allsum(const cn_share *sh, cn_xsum *v, size_t n)
{
    return sh && sh->size > 1 ? sh->allsum(sh->ctx, v, n) : 0;
}

#endif /* CNERF_ENC_XSUM_H */
