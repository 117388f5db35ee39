/*
 * Arm kernels, chosen at compile time: the DSP extension's dual 16-bit multiply-accumulate
 * (Cortex-M4, M7, M33: __smlad from arm_acle.h), Helium (Cortex-M55, M85: arm_mve.h) and
 * Advanced SIMD (aarch64: arm_neon.h). Each computes exactly cn_dot_c's sums (cn_kernels.h).
 */
#include "../common/cn_fixed.h"
#include "cn_kernels.h"

#if defined(CN_HAVE_MVE)
#include <arm_mve.h>
#endif
#if defined(CN_HAVE_DSP)
#include <arm_acle.h>
#endif
#if defined(CN_HAVE_NEON)
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

#if !defined(CN_HAVE_MVE)
/* One step of the inner loop: two input words (one LDRD) against the block's eight latent
 * words (four LDRDs), eight dual multiply-accumulates. */
#define CN_DSP_STEP                                                                         \
    "ldrd %[x0], %[x1], [%[xp]], #8\n\t"                                                    \
    "ldrd %[w0], %[w1], [%[k]], #8\n\t"                                                     \
    "ldrd %[w2], %[w3], [%[k]], #8\n\t"                                                     \
    "smlad %[a0], %[w0], %[x0], %[a0]\n\t"                                                  \
    "smlad %[a1], %[w1], %[x0], %[a1]\n\t"                                                  \
    "smlad %[a2], %[w2], %[x0], %[a2]\n\t"                                                  \
    "smlad %[a3], %[w3], %[x0], %[a3]\n\t"                                                  \
    "ldrd %[w0], %[w1], [%[k]], #8\n\t"                                                     \
    "ldrd %[w2], %[w3], [%[k]], #8\n\t"                                                     \
    "smlad %[a0], %[w0], %[x1], %[a0]\n\t"                                                  \
    "smlad %[a1], %[w1], %[x1], %[a1]\n\t"                                                  \
    "smlad %[a2], %[w2], %[x1], %[a2]\n\t"                                                  \
    "smlad %[a3], %[w3], %[x1], %[a3]\n\t"

/* Four rows at a time, eight input pairs per loop iteration (four steps: 56 instructions
 * and the loop's compare and branch for 64 multiply-accumulates), then steps for the
 * remaining pairs two at a time and __smlad for a last odd pair. Every load is an LDRD with
 * write-back, so no operand spills. */
void cn_dot_arm(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                int32_t *acc)
{
    uint32_t j = 0;
    for (; j + 4u <= n_rows; j += 4u) {
        int32_t a0 = 0, a1 = 0, a2 = 0, a3 = 0;
        const int16_t *xp = x;
        int32_t x0, x1, w0, w1, w2, w3;
        if (n_pairs >= 8u) {
            const int16_t *end = k + 64u * (n_pairs >> 3);
            __asm__("1:\n\t" CN_DSP_STEP CN_DSP_STEP CN_DSP_STEP CN_DSP_STEP
                    "cmp %[k], %[end]\n\t"
                    "bne 1b"
                    : [a0] "+r"(a0), [a1] "+r"(a1), [a2] "+r"(a2), [a3] "+r"(a3), [k] "+r"(k),
                      [xp] "+r"(xp), [x0] "=&r"(x0), [x1] "=&r"(x1), [w0] "=&r"(w0),
                      [w1] "=&r"(w1), [w2] "=&r"(w2), [w3] "=&r"(w3)
                    : [end] "r"(end)
                    : "cc", "memory");
        }
        for (uint32_t r = (n_pairs & 7u) >> 1; r > 0u; r--) {
            __asm__(CN_DSP_STEP
                    : [a0] "+r"(a0), [a1] "+r"(a1), [a2] "+r"(a2), [a3] "+r"(a3), [k] "+r"(k),
                      [xp] "+r"(xp), [x0] "=&r"(x0), [x1] "=&r"(x1), [w0] "=&r"(w0),
                      [w1] "=&r"(w1), [w2] "=&r"(w2), [w3] "=&r"(w3)
                    :
                    : "memory");
        }
        if (n_pairs & 1u) {
            const int32_t xv = rd2(xp);
            a0 = __smlad(rd2(k), xv, a0);
            a1 = __smlad(rd2(k + 2), xv, a1);
            a2 = __smlad(rd2(k + 4), xv, a2);
            a3 = __smlad(rd2(k + 6), xv, a3);
            k += 8;
        }
        acc[j] = a0, acc[j + 1u] = a1, acc[j + 2u] = a2, acc[j + 3u] = a3;
    }
    /* the last one to three rows (a density or colour head, or a block's remainder), row
     * after row: one SMLAD an input pair */
    for (; j < n_rows; j++) {
        int32_t a = 0;
        for (uint32_t p = 0; p < n_pairs; p++, k += 2)
            a = __smlad(rd2(k), rd2(x + 2u * p), a);
        acc[j] = a;
    }
}

/* A layer's inputs at its scale for 1 <= s <= 16 (render.c's requant: sat16 of x plus
 * 2^(s-1) saturated, shifted right by s), two at a time: one LDRD, two QADDs, two shifts,
 * two SSATs, one PKHBT packing the pair, one store, and one SMLAD with (1, 1) adding both
 * to the sum. Returns the sum. */
#endif /* the DSP extension's sums where there is no Helium */

/* render.c's finish_fast for n < 32, two outputs per step: y[j] = sat32(sat32(((acc[j] a_m
 * + 2^(n-1)) >> n) + t) + bq[j]), then max(0, .) when relu. The 64-bit value starts at
 * 2^(n-1) and SMLAL adds the product; its low word after the shift is the result (|result|
 * < 2^30, cnerf_open's proof). 23 instructions for two outputs. */
#define CN_FIN_STEP(RELU)                                                                   \
    "ldrd %[a0], %[a1], [%[acc]], #8\n\t"                                                   \
    "mov %[lo], %[half]\n\t"                                                                \
    "mov %[hi], #0\n\t"                                                                     \
    "smlal %[lo], %[hi], %[a0], %[am]\n\t"                                                  \
    "lsr %[lo], %[lo], %[n]\n\t"                                                            \
    "lsl %[hi], %[hi], %[m]\n\t"                                                            \
    "orr %[a0], %[lo], %[hi]\n\t"                                                           \
    "mov %[lo], %[half]\n\t"                                                                \
    "mov %[hi], #0\n\t"                                                                     \
    "smlal %[lo], %[hi], %[a1], %[am]\n\t"                                                  \
    "lsr %[lo], %[lo], %[n]\n\t"                                                            \
    "lsl %[hi], %[hi], %[m]\n\t"                                                            \
    "orr %[a1], %[lo], %[hi]\n\t"                                                           \
    "ldrd %[lo], %[hi], [%[bq]], #8\n\t"                                                    \
    "qadd %[a0], %[a0], %[t]\n\t"                                                           \
    "qadd %[a0], %[a0], %[lo]\n\t"                                                          \
    "qadd %[a1], %[a1], %[t]\n\t"                                                           \
    "qadd %[a1], %[a1], %[hi]\n\t" RELU                                                     \
    "strd %[a0], %[a1], [%[y]], #8\n\t"                                                     \
    "cmp %[acc], %[end]\n\t"                                                                \
    "bne 1b"
#define CN_FIN_RELU "bic %[a0], %[a0], %[a0], asr #31\n\tbic %[a1], %[a1], %[a1], asr #31\n\t"
#define CN_FIN_OPERANDS                                                                     \
    : [acc] "+r"(acc), [bq] "+r"(bq), [y] "+r"(y), [a0] "=&r"(a0), [a1] "=&r"(a1),           \
      [lo] "=&r"(lo), [hi] "=&r"(hi)                                                         \
    : [end] "r"(end), [am] "r"(am), [half] "r"(half), [n] "r"(n), [m] "r"(32u - n),          \
      [t] "r"(t)                                                                             \
    : "cc", "memory"

void cn_finish_arm(const int32_t *acc, uint32_t live, int32_t am, unsigned n, int32_t t,
                   const int32_t *bq, int32_t *y, int relu)
{
    const uint32_t half = (uint32_t)1 << (n - 1u);
    if (live >= 2u) {
        const int32_t *end = acc + (live & ~1u);
        int32_t a0, a1, lo, hi;
        if (relu)
            __asm__("1:\n\t" CN_FIN_STEP(CN_FIN_RELU) CN_FIN_OPERANDS);
        else
            __asm__("1:\n\t" CN_FIN_STEP("") CN_FIN_OPERANDS);
    }
    if (live & 1u) {
        const uint64_t u = (uint64_t)((int64_t)*acc * am) + half;
        const int32_t v = cn_qadd32(cn_qadd32(cn_s32(((uint32_t)u >> n) | ((uint32_t)(u >> 32) << (32u - n))), t), *bq);
        *y = relu && v < 0 ? 0 : v;
    }
}

int32_t cn_requant_arm(const int32_t *x, int16_t *xq, uint32_t n, unsigned s)
{
    const int32_t h = (int32_t)1 << (s - 1u), ones = 0x00010001;
    int32_t sum = 0;
    if (n >= 2u) {
        const int32_t *end = x + (n & ~1u);
        int32_t a, b;
        __asm__("1:\n\t"
                "ldrd %[a], %[b], [%[x]], #8\n\t"
                "qadd %[a], %[a], %[h]\n\t"
                "qadd %[b], %[b], %[h]\n\t"
                "asr %[a], %[a], %[s]\n\t"
                "asr %[b], %[b], %[s]\n\t"
                "ssat %[a], #16, %[a]\n\t"
                "ssat %[b], #16, %[b]\n\t"
                "pkhbt %[a], %[a], %[b], lsl #16\n\t"
                "str %[a], [%[q]], #4\n\t"
                "smlad %[sum], %[a], %[ones], %[sum]\n\t"
                "cmp %[x], %[end]\n\t"
                "bne 1b"
                : [sum] "+r"(sum), [x] "+r"(x), [q] "+r"(xq), [a] "=&r"(a), [b] "=&r"(b)
                : [h] "r"(h), [s] "r"(s), [ones] "r"(ones), [end] "r"(end)
                : "cc", "memory");
    }
    if (n & 1u) {
        int32_t v;
        __asm__("qadd %0, %1, %2\n\t"
                "asr %0, %0, %3\n\t"
                "ssat %0, #16, %0"
                : "=&r"(v)
                : "r"(*x), "r"(h), "r"(s));
        *xq = (int16_t)v;
        sum += v;
    }
    return sum;
}
#endif

#if defined(CN_HAVE_MVE)
/* Each vector holds one input pair of the block's four rows; multiplied lane by lane with
 * the pair repeated four times, the bottom (even) lanes give k[r][2p] x[2p] and the top
 * (odd) lanes k[r][2p+1] x[2p+1], both as four int32. Two pairs a step, into two
 * accumulators. */
void cn_dot_arm(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                int32_t *acc)
{
    uint32_t j = 0;
    for (; j + 4u <= n_rows; j += 4u) {
        int32x4_t a = vdupq_n_s32(0), b = vdupq_n_s32(0);
        const int16_t *xp = x;
        for (uint32_t p = n_pairs >> 1; p > 0u; p--) {
            int32_t xa, xb;
            __builtin_memcpy(&xa, xp, 4);
            __builtin_memcpy(&xb, xp + 2, 4);
            xp += 4;
            const int16x8_t x0 = vreinterpretq_s16_s32(vdupq_n_s32(xa));
            const int16x8_t x1 = vreinterpretq_s16_s32(vdupq_n_s32(xb));
            const int16x8_t w0 = vld1q_s16(k), w1 = vld1q_s16(k + 8);
            k += 16;
            a = vaddq_s32(a, vmullbq_int_s16(w0, x0));
            b = vaddq_s32(b, vmulltq_int_s16(w0, x0));
            a = vaddq_s32(a, vmullbq_int_s16(w1, x1));
            b = vaddq_s32(b, vmulltq_int_s16(w1, x1));
        }
        if (n_pairs & 1u) {
            int32_t xv;
            __builtin_memcpy(&xv, xp, 4);
            const int16x8_t xx = vreinterpretq_s16_s32(vdupq_n_s32(xv));
            const int16x8_t w = vld1q_s16(k);
            k += 8;
            a = vaddq_s32(a, vmullbq_int_s16(w, xx));
            b = vaddq_s32(b, vmulltq_int_s16(w, xx));
        }
        vst1q_s32(acc + j, vaddq_s32(a, b));
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
#if defined(CN_HAVE_MVE)
    out[n].name = "mve";
#if defined(CN_HAVE_DSP)
    out[n].requant = cn_requant_arm;
    out[n].finish = cn_finish_arm;
#else
    out[n].requant = (cn_requant_fn)0;
    out[n].finish = (cn_finish_fn)0;
#endif
    out[n++].fn = cn_dot_arm;
#elif defined(CN_HAVE_DSP)
    out[n].name = "dsp";
    out[n].requant = cn_requant_arm;
    out[n].finish = cn_finish_arm;
    out[n++].fn = cn_dot_arm;
#elif defined(CN_HAVE_NEON)
    out[n].name = "neon";
    out[n].requant = (cn_requant_fn)0;
    out[n].finish = (cn_finish_fn)0;
    out[n++].fn = cn_dot_arm;
#else
    (void)out;
#endif
    return n;
}
