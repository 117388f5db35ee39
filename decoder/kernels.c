/*
 * The portable dot-product kernels, which define the sums, and the choice among the kernels
 * of kernels_dsp.c, kernels_mve.c, kernels_neon.c and kernels_avx2.c: the one place of the
 * dispatch.
 */
#include "cn_kernels.h"

void cn_dot_s16_c(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                  int32_t *acc)
{
    uint32_t j = 0;
    for (; j + 4u <= n_rows; j += 4u) {
        int32_t a0 = 0, a1 = 0, a2 = 0, a3 = 0;
        for (uint32_t p = 0; p < n_pairs; p++, k += 8) {
            const int32_t x0 = x[2u * p], x1 = x[2u * p + 1u];
            a0 += k[0] * x0 + k[1] * x1;
            a1 += k[2] * x0 + k[3] * x1;
            a2 += k[4] * x0 + k[5] * x1;
            a3 += k[6] * x0 + k[7] * x1;
        }
        acc[j] = a0, acc[j + 1u] = a1, acc[j + 2u] = a2, acc[j + 3u] = a3;
    }
    for (; j < n_rows; j++, k += 2u * n_pairs) { /* the last one to three rows, row by row */
        int32_t a = 0;
        for (uint32_t i = 0; i < 2u * n_pairs; i++)
            a += k[i] * x[i];
        acc[j] = a;
    }
}

void cn_dot_s16_s64_c(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                      int64_t *acc)
{
    uint32_t j = 0;
    for (; j + 4u <= n_rows; j += 4u) {
        int64_t a[4]; /* element by element: an initializer may become a memset call */
        a[0] = a[1] = a[2] = a[3] = 0;
        for (uint32_t p = 0; p < n_pairs; p++, k += 8) {
            const int64_t x0 = x[2u * p], x1 = x[2u * p + 1u];
            for (uint32_t q = 0; q < 4u; q++)
                a[q] += k[2u * q] * x0 + k[2u * q + 1u] * x1;
        }
        for (uint32_t q = 0; q < 4u; q++)
            acc[j + q] = a[q];
    }
    for (; j < n_rows; j++, k += 2u * n_pairs) {
        int64_t a = 0;
        for (uint32_t i = 0; i < 2u * n_pairs; i++)
            a += (int64_t)k[i] * x[i];
        acc[j] = a;
    }
}

/* One entry of the list; returns 1. */
static uint32_t variant(cn_dot_variant *v, const char *name, cn_dot_fn fn, cn_requant_fn requant,
                        cn_finish_fn finish)
{
    v->name = name;
    v->fn = fn;
    v->requant = requant;
    v->finish = finish;
    return 1;
}

uint32_t cn_dot_variants(cn_dot_variant out[CN_DOT_MAX_VARIANTS])
{
    const cn_requant_fn c_requant = (cn_requant_fn)0; /* render.c's portable C */
    const cn_finish_fn c_finish = (cn_finish_fn)0;
    uint32_t n = variant(out, "c", cn_dot_s16_c, c_requant, c_finish);
#if defined(CN_HAVE_AVX2)
    if (cn_cpu_has_avx2())
        n += variant(out + n, "avx2", cn_dot_s16_avx2, cn_requant_s16_avx2, cn_finish_s32_avx2);
#endif
    /* Arm: one set, fixed at compile time */
#if defined(CN_HAVE_MVE) && defined(CN_HAVE_DSP)
    n += variant(out + n, "mve", cn_dot_s16_mve, cn_requant_s16_dsp, cn_finish_s32_dsp);
#elif defined(CN_HAVE_MVE)
    n += variant(out + n, "mve", cn_dot_s16_mve, c_requant, c_finish);
#elif defined(CN_HAVE_DSP)
    n += variant(out + n, "dsp", cn_dot_s16_dsp, cn_requant_s16_dsp, cn_finish_s32_dsp);
#elif defined(CN_HAVE_NEON)
    n += variant(out + n, "neon", cn_dot_s16_neon, c_requant, c_finish);
#endif
    return n;
}

cn_dot_variant cn_dot_select(void)
{
    cn_dot_variant v[CN_DOT_MAX_VARIANTS];
    return v[cn_dot_variants(v) - 1u]; /* the list ends with the fastest */
}
