/*
 * Arm kernels, chosen at compile time: the DSP extension's dual 16-bit multiply-accumulate
 * (Cortex-M4, M7, M33: __smlad from arm_acle.h), Helium (Cortex-M55, M85: arm_mve.h) and
 * Advanced SIMD (aarch64: arm_neon.h). Each computes exactly cn_dot_c's sums (cn_kernels.h).
 */
#include "cn_kernels.h"

#if defined(CN_HAVE_MVE)
#include <arm_mve.h>
#elif defined(CN_HAVE_DSP)
#include <arm_acle.h>
#elif defined(CN_HAVE_NEON)
#include <arm_neon.h>
#endif

#if defined(CN_HAVE_DSP)
/* Two int16 of the packed latents or of the inputs as one word (an aligned load). */
static inline int32_t rd2(const int16_t *p)
{
    int32_t v;
    __builtin_memcpy(&v, p, 4);
    return v;
}

/* Four rows at a time, two input pairs per step: one doubleword load of the two input
 * words, four of the block's eight latent words and eight dual multiply-accumulates
 * (__smlad's instruction; the step is written out so that every load is an LDRD with
 * write-back and no operand spills: 15 instructions for 16 multiply-accumulates). */
void cn_dot_arm(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                int32_t *acc)
{
    uint32_t j = 0;
    for (; j + 4u <= n_rows; j += 4u) {
        int32_t a0 = 0, a1 = 0, a2 = 0, a3 = 0;
        const int16_t *xp = x;
        if (n_pairs >= 2u) {
            const int16_t *end = k + 16u * (n_pairs >> 1);
            int32_t x0, x1, w0, w1, w2, w3;
            __asm__("1:\n\t"
                    "ldrd %[x0], %[x1], [%[xp]], #8\n\t"
                    "ldrd %[w0], %[w1], [%[k]], #8\n\t"
                    "ldrd %[w2], %[w3], [%[k]], #8\n\t"
                    "smlad %[a0], %[w0], %[x0], %[a0]\n\t"
                    "smlad %[a1], %[w1], %[x0], %[a1]\n\t"
                    "smlad %[a2], %[w2], %[x0], %[a2]\n\t"
                    "smlad %[a3], %[w3], %[x0], %[a3]\n\t"
                    "ldrd %[w0], %[w1], [%[k]], #8\n\t"
                    "ldrd %[w2], %[w3], [%[k]], #8\n\t"
                    "smlad %[a0], %[w0], %[x1], %[a0]\n\t"
                    "smlad %[a1], %[w1], %[x1], %[a1]\n\t"
                    "smlad %[a2], %[w2], %[x1], %[a2]\n\t"
                    "smlad %[a3], %[w3], %[x1], %[a3]\n\t"
                    "cmp %[k], %[end]\n\t"
                    "bne 1b"
                    : [a0] "+r"(a0), [a1] "+r"(a1), [a2] "+r"(a2), [a3] "+r"(a3), [k] "+r"(k),
                      [xp] "+r"(xp), [x0] "=&r"(x0), [x1] "=&r"(x1), [w0] "=&r"(w0),
                      [w1] "=&r"(w1), [w2] "=&r"(w2), [w3] "=&r"(w3)
                    : [end] "r"(end)
                    : "cc", "memory");
        }
        if (n_pairs & 1u) {
            const int32_t x0 = rd2(xp);
            a0 = __smlad(rd2(k), x0, a0);
            a1 = __smlad(rd2(k + 2), x0, a1);
            a2 = __smlad(rd2(k + 4), x0, a2);
            a3 = __smlad(rd2(k + 6), x0, a3);
            k += 8;
        }
        acc[j] = a0, acc[j + 1u] = a1, acc[j + 2u] = a2, acc[j + 3u] = a3;
    }
    if (j < n_rows)
        cn_dot_c(k, x, n_pairs, n_rows - j, acc + j);
}
#endif

#if defined(CN_HAVE_MVE)
/* Each vector holds one input pair of the block's four rows; multiplied lane by lane with
 * the pair repeated four times, the bottom (even) lanes give k[r][2p] x[2p] and the top
 * (odd) lanes k[r][2p+1] x[2p+1], both as four int32. */
void cn_dot_arm(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                int32_t *acc)
{
    uint32_t j = 0;
    for (; j + 4u <= n_rows; j += 4u) {
        int32x4_t a = vdupq_n_s32(0);
        for (uint32_t p = 0; p < n_pairs; p++, k += 8) {
            int32_t xv;
            __builtin_memcpy(&xv, x + 2u * p, 4);
            const int16x8_t xx = vreinterpretq_s16_s32(vdupq_n_s32(xv));
            const int16x8_t w = vld1q_s16(k);
            a = vaddq_s32(a, vmullbq_int_s16(w, xx));
            a = vaddq_s32(a, vmulltq_int_s16(w, xx));
        }
        vst1q_s32(acc + j, a);
    }
    if (j < n_rows)
        cn_dot_c(k, x, n_pairs, n_rows - j, acc + j);
}
#endif

#if defined(CN_HAVE_NEON)
void cn_dot_arm(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                int32_t *acc)
{
    uint32_t j = 0;
    for (; j + 4u <= n_rows; j += 4u) {
        int32x4_t lo = vdupq_n_s32(0), hi = vdupq_n_s32(0);
        for (uint32_t p = 0; p < n_pairs; p++, k += 8) {
            int32_t xv;
            __builtin_memcpy(&xv, x + 2u * p, 4);
            const int16x8_t xx = vreinterpretq_s16_s32(vdupq_n_s32(xv));
            const int16x8_t w = vld1q_s16(k);
            lo = vmlal_s16(lo, vget_low_s16(w), vget_low_s16(xx)); /* rows 0, 1 */
            hi = vmlal_high_s16(hi, w, xx);                         /* rows 2, 3 */
        }
        vst1q_s32(acc + j, vpaddq_s32(lo, hi));
    }
    if (j < n_rows)
        cn_dot_c(k, x, n_pairs, n_rows - j, acc + j);
}
#endif

uint32_t cn_dot_variants_arm(cn_dot_variant *out)
{
    uint32_t n = 0;
#if defined(CN_HAVE_DSP)
    out[n].name = "dsp";
    out[n++].fn = cn_dot_arm;
#elif defined(CN_HAVE_MVE)
    out[n].name = "mve";
    out[n++].fn = cn_dot_arm;
#elif defined(CN_HAVE_NEON)
    out[n].name = "neon";
    out[n++].fn = cn_dot_arm;
#else
    (void)out;
#endif
    return n;
}
