/*
 * The portable dot-product kernels, which define the sums, and the choice among the kernels
 * of kernels_dsp.c, kernels_mve.c, kernels_neon.c, kernels_simd128.c and kernels_avx2.c: the
 * one place of the dispatch.
 */
#include "cn_kernels.h"

/* The kernels' costs (cn_dot_variant), in sixteenths of the packed sums' cost per
 * multiply-accumulate on the same core. x86-64 (c, avx2): the medians of check_kernels
 * --bench. Arm: the instructions of the loops, which QEMU counts (the packed DSP sums: 58
 * for 64 multiply-accumulates; the lists: 9 for two non-zeros and about 10 a row; Helium: 10
 * for 32 and 8 a block of four rows, 6 sixteenths a multiply-accumulate on 64 inputs, its
 * lists the DSP's; Advanced SIMD: 8 for 8, its lists as the DSP's). The portable C's ratios
 * are x86-64's. The packed sums over int8 latents (MAC8): on Arm the same count of their
 * loops (the DSP's 78 for 64, with the SXTB16s; Helium's as its int16 loop, VLDRB.S16 for
 * VLDRH; Advanced SIMD's 9 for 8, with the vmovl), elsewhere taken as the int16 sums' (their
 * widening loads were not timed apart). */
#define C_MAC 16u
#define C_NZ 38u
#define C_ROW 48u
#define C_MAC8 C_MAC
#define AVX2_MAC 16u
#define AVX2_NZ 300u
#define AVX2_ROW 300u
#define AVX2_MAC8 AVX2_MAC
#define SIMD128_MAC 16u /* check_kernels --bench built for wasm32, under Node 20 on x86-64 */
#define SIMD128_NZ 153u
#define SIMD128_ROW 766u
#define SIMD128_MAC8 SIMD128_MAC
#define NEON_MAC 16u
#define NEON_NZ 72u
#define NEON_ROW 160u
#define NEON_MAC8 18u
#define MVE_MAC 6u
#define MVE_MAC8 6u
#define DSP_MAC 15u
#define DSP_MAC8 20u
#define DSP_NZ 72u
#define DSP_ROW 160u

/* The portable sums, one definition for each latent type KT (int16, int8) and accumulator
 * type AT (int32 where cnerf_open proved the bound, else int64), in layout CN_PAIRS: four
 * rows a block, each in its own variable (at -Os, as firmware builds, an array of four would
 * live on the stack), then the last one to three rows row by row. */
#define CN_DOT_C(NAME, KT, AT)                                                              \
    void NAME(const KT *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows, AT *acc)    \
    {                                                                                       \
        uint32_t j = 0;                                                                     \
        for (; j + 4u <= n_rows; j += 4u) {                                                 \
            AT a0 = 0, a1 = 0, a2 = 0, a3 = 0;                                              \
            for (uint32_t p = 0; p < n_pairs; p++, k += 8) {                                \
                const AT x0 = x[2u * p], x1 = x[2u * p + 1u];                               \
                a0 += k[0] * x0 + k[1] * x1;                                                \
                a1 += k[2] * x0 + k[3] * x1;                                                \
                a2 += k[4] * x0 + k[5] * x1;                                                \
                a3 += k[6] * x0 + k[7] * x1;                                                \
            }                                                                               \
            acc[j] = a0, acc[j + 1u] = a1, acc[j + 2u] = a2, acc[j + 3u] = a3;              \
        }                                                                                   \
        for (; j < n_rows; j++, k += 2u * n_pairs) {                                        \
            AT a = 0;                                                                       \
            for (uint32_t i = 0; i < 2u * n_pairs; i++)                                     \
                a += (AT)k[i] * x[i];                                                       \
            acc[j] = a;                                                                     \
        }                                                                                   \
    }

CN_DOT_C(cn_dot_s16_c, int16_t, int32_t)
CN_DOT_C(cn_dot_s16_s64_c, int16_t, int64_t)
CN_DOT_C(cn_dot_s8_c, int8_t, int32_t)
CN_DOT_C(cn_dot_s8_s64_c, int8_t, int64_t)

uint32_t cn_spdot_s16_c(const uint32_t *e, const int16_t *x, uint32_t n_rows, int32_t *acc)
{
    uint32_t total = 0;
    for (uint32_t j = 0; j < n_rows; j++) {
        uint32_t n = *e++;
        total += n;
        int32_t a = 0;
        for (; n >= 2u; n -= 2u, e += 2) {
            a += cn_entry_k(e[0]) * x[e[0] >> 17];
            a += cn_entry_k(e[1]) * x[e[1] >> 17];
        }
        if (n)
            a += cn_entry_k(*e) * x[*e >> 17], e++;
        acc[j] = a;
    }
    return total;
}

/* The costs {per multiply-accumulate, per non-zero latent, per row} of each set, in
 * sixteenths (above; docs/decoder.md, "Zero latents"). Helium's sets use the DSP's lists. */
static const uint16_t c_cost[4] = {C_MAC, C_NZ, C_ROW, C_MAC8};
static const uint16_t dsp_cost[4] = {DSP_MAC, DSP_NZ, DSP_ROW, DSP_MAC8};
static const uint16_t mve_cost[4] = {MVE_MAC, DSP_NZ, DSP_ROW, MVE_MAC8};
static const uint16_t neon_cost[4] = {NEON_MAC, NEON_NZ, NEON_ROW, NEON_MAC8};
static const uint16_t simd128_cost[4] = {SIMD128_MAC, SIMD128_NZ, SIMD128_ROW, SIMD128_MAC8};
static const uint16_t avx2_cost[4] = {AVX2_MAC, AVX2_NZ, AVX2_ROW, AVX2_MAC8};

/* One entry of the list, with its kernels' costs (sixteenths, cn_dot_variant); returns 1. */
static uint32_t variant(cn_dot_variant *v, const char *name, cn_dot_fn fn, cn_dot8_fn fn8,
                        cn_requant_fn requant, cn_finish_fn finish, cn_spdot_fn spdot,
                        const uint16_t cost[4], uint8_t layout, uint8_t layout8)
{
    v->layout = layout;
    v->layout8 = layout8;
    v->name = name;
    v->fn = fn;
    v->fn8 = fn8;
    v->requant = requant;
    v->finish = finish;
    v->spdot = spdot;
    v->mac_cost = cost[0];
    v->nz_cost = cost[1];
    v->row_cost = cost[2];
    v->mac8_cost = cost[3];
    return 1;
}

uint32_t cn_dot_variants(cn_dot_variant out[CN_DOT_MAX_VARIANTS])
{
    const cn_requant_fn c_requant = (cn_requant_fn)0; /* render.c's portable C */
    const cn_finish_fn c_finish = (cn_finish_fn)0;
    uint32_t n = variant(out, "c", cn_dot_s16_c, cn_dot_s8_c, c_requant, c_finish,
                         cn_spdot_s16_c, c_cost, CN_PAIRS, CN_PAIRS);
#if defined(CN_HAVE_AVX2)
    if (cn_cpu_has_avx2())
        n += variant(out + n, "avx2", cn_dot_s16_avx2, cn_dot_s8_avx2, cn_requant_s16_avx2,
                     cn_finish_s32_avx2, cn_spdot_s16_c, avx2_cost, CN_PAIRS, CN_PAIRS);
#endif
    /* Arm: one set, fixed at compile time */
#if defined(CN_HAVE_MVE) && defined(CN_HAVE_DSP)
    n += variant(out + n, "mve", cn_dot_s16_mve, cn_dot_s8_mve, cn_requant_s16_mve,
                 cn_finish_s32_mve, cn_spdot_s16_dsp, mve_cost, CN_RUNS8, CN_RUNS8);
#elif defined(CN_HAVE_MVE)
    n += variant(out + n, "mve", cn_dot_s16_mve, cn_dot_s8_mve, cn_requant_s16_mve,
                 cn_finish_s32_mve, cn_spdot_s16_c, mve_cost, CN_RUNS8, CN_RUNS8);
#elif defined(CN_HAVE_DSP)
    n += variant(out + n, "dsp", cn_dot_s16_dsp, cn_dot_s8_dsp, cn_requant_s16_dsp,
                 cn_finish_s32_dsp, cn_spdot_s16_dsp, dsp_cost, CN_PAIRS, CN_PAIRS_X);
#elif defined(CN_HAVE_NEON)
    n += variant(out + n, "neon", cn_dot_s16_neon, cn_dot_s8_neon, c_requant, c_finish,
                 cn_spdot_s16_c, neon_cost, CN_PAIRS, CN_PAIRS);
#endif
#if defined(CN_HAVE_SIMD128) /* WebAssembly: fixed at compile time (-msimd128) */
    n += variant(out + n, "simd128", cn_dot_s16_simd128, cn_dot_s8_simd128,
                 cn_requant_s16_simd128, cn_finish_s32_simd128, cn_spdot_s16_c, simd128_cost,
                 CN_PAIRS, CN_PAIRS);
#endif
    return n;
}

/* 1 when the NUL-terminated a and b are equal (no libc here). */
static int same(const char *a, const char *b)
{
    while (*a && *a == *b)
        a++, b++;
    return *a == *b;
}

/* The sets by name: their costs, and the layouts their own kernels read. */
static int set_named(const char *set, int own_layouts, cn_dot_variant *out)
{
    static const struct {
        const char *name;
        const uint16_t *cost;
        uint8_t layout, layout8;
    } sets[] = {{"c", c_cost, CN_PAIRS, CN_PAIRS},
                {"dsp", dsp_cost, CN_PAIRS, CN_PAIRS_X},
                {"mve", mve_cost, CN_RUNS8, CN_RUNS8},
                {"neon", neon_cost, CN_PAIRS, CN_PAIRS},
                {"simd128", simd128_cost, CN_PAIRS, CN_PAIRS},
                {"avx2", avx2_cost, CN_PAIRS, CN_PAIRS}};
    for (uint32_t i = 0; set && i < sizeof sets / sizeof sets[0]; i++)
        if (same(set, sets[i].name))
            return (int)variant(out, sets[i].name, cn_dot_s16_c, cn_dot_s8_c, (cn_requant_fn)0,
                                (cn_finish_fn)0, cn_spdot_s16_c, sets[i].cost,
                                own_layouts ? sets[i].layout : CN_PAIRS,
                                own_layouts ? sets[i].layout8 : CN_PAIRS);
    return 0;
}

int cn_dot_variant_as(const char *set, cn_dot_variant *out) { return set_named(set, 0, out); }

int cn_dot_variant_target(const char *set, cn_dot_variant *out)
{
    return set_named(set, 1, out);
}

cn_dot_variant cn_dot_select(void)
{
    cn_dot_variant v[CN_DOT_MAX_VARIANTS];
    return v[cn_dot_variants(v) - 1u]; /* the list ends with the fastest */
}
