/*
 * The Arm DSP extension's kernels (Cortex-M4, M7, M33, M55; Armv7-A): dual 16-bit
 * multiply-accumulates (SMLAD), saturating additions and packing. cn_dot_s16_dsp and
 * cn_dot_s8_dsp (int8 latents widened by SXTB16) compute exactly cn_dot_s16_c's and
 * cn_dot_s8_c's sums, cn_requant_s16_dsp and cn_finish_s32_dsp render.c's input
 * quantization and output rescale (cn_kernels.h). Where Helium is there too (Cortex-M55) its
 * sums are the faster ones (mve.c), and the sums here are not built.
 */
#include "../common/cn_fixed.h"
#include "cn_kernels.h"

#if defined(CN_HAVE_DSP)
#include <arm_acle.h>

#if !defined(CN_HAVE_MVE)
/* Two int16 of the packed latents or of the inputs as one word (an aligned load). */
static inline int32_t rd2(const int16_t *p)
{
    int32_t v;
    __builtin_memcpy(&v, p, 4);
    return v;
}

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
void cn_dot_s16_dsp(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
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

/* The int8 sums of a step of two input pairs in layout CN_PAIRS_X: one LDRD of the two
 * input words and, per pair, one LDRD of its eight latent bytes and per word two SXTB16
 * (bytes 0 and 2 as one row's pair; rotated by 8, bytes 1 and 3 as the next row's) and two
 * SMLAD: 19 instructions for 16 multiply-accumulates. */
#define CN_DSP8_PAIR(X)                                                                     \
    "ldrd %[w0], %[w1], [%[k]], #8\n\t"                                                     \
    "sxtb16 %[t], %[w0], ror #8\n\t"                                                        \
    "sxtb16 %[w0], %[w0]\n\t"                                                               \
    "smlad %[a0], %[w0], %[" X "], %[a0]\n\t"                                               \
    "smlad %[a1], %[t], %[" X "], %[a1]\n\t"                                                \
    "sxtb16 %[t], %[w1], ror #8\n\t"                                                        \
    "sxtb16 %[w1], %[w1]\n\t"                                                               \
    "smlad %[a2], %[w1], %[" X "], %[a2]\n\t"                                               \
    "smlad %[a3], %[t], %[" X "], %[a3]\n\t"
#define CN_DSP8_STEP "ldrd %[x0], %[x1], [%[xp]], #8\n\t" CN_DSP8_PAIR("x0") CN_DSP8_PAIR("x1")

/* The last one to three rows of cn_dot_s8_dsp, each row's latents in turn (cn_kernels.h),
 * four a step: one word of four latents k0..k3, SXTB16 of it ([k0, k2]) and of it rotated by
 * 8 ([k1, k3]), against the inputs x0..x3 packed as [x0, x2] and [x1, x3] (PKHBT, PKHTB): two
 * SMLADs. A last odd pair by the C. The same int32 sums as cn_dot_s8_c's, row after row. */
static void rows_s8_dsp(const int8_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                        int32_t *acc)
{
    const uint32_t n = 2u * n_pairs;
    for (uint32_t j = 0; j < n_rows; j++, k += n) {
        int32_t a = 0;
        uint32_t i = 0;
        for (; i + 4u <= n; i += 4u) {
            uint32_t w;
            __builtin_memcpy(&w, k + i, 4);
            const uint32_t x01 = (uint32_t)rd2(x + i), x23 = (uint32_t)rd2(x + i + 2);
            const int32_t xe = (int32_t)((x01 & 0xffffu) | (x23 << 16));
            const int32_t xo = (int32_t)((x01 >> 16) | (x23 & 0xffff0000u));
            a = __smlad(__sxtb16((int8x4_t)w), xe, a);
            a = __smlad(__sxtb16((int8x4_t)(w >> 8 | w << 24)), xo, a);
        }
        if (i < n)
            a += k[i] * x[i] + k[i + 1u] * x[i + 1u];
        acc[j] = a;
    }
}

/* cn_dot_s8_c's sums over latents in layout CN_PAIRS_X: four rows at a time, eight input
 * pairs per loop iteration (four steps), then steps for the remaining pairs two at a time
 * and the intrinsics for a last odd pair; the last one to three rows by rows_s8_dsp. */
void cn_dot_s8_dsp(const int8_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                   int32_t *acc)
{
    uint32_t j = 0;
    for (; j + 4u <= n_rows; j += 4u) {
        int32_t a0 = 0, a1 = 0, a2 = 0, a3 = 0;
        const int16_t *xp = x;
        int32_t x0, x1, w0, w1, t;
        if (n_pairs >= 8u) {
            const int8_t *end = k + 64u * (n_pairs >> 3);
            __asm__("1:\n\t" CN_DSP8_STEP CN_DSP8_STEP CN_DSP8_STEP CN_DSP8_STEP
                    "cmp %[k], %[end]\n\t"
                    "bne 1b"
                    : [a0] "+r"(a0), [a1] "+r"(a1), [a2] "+r"(a2), [a3] "+r"(a3), [k] "+r"(k),
                      [xp] "+r"(xp), [x0] "=&r"(x0), [x1] "=&r"(x1), [w0] "=&r"(w0),
                      [w1] "=&r"(w1), [t] "=&r"(t)
                    : [end] "r"(end)
                    : "cc", "memory");
        }
        for (uint32_t r = (n_pairs & 7u) >> 1; r > 0u; r--) {
            __asm__(CN_DSP8_STEP
                    : [a0] "+r"(a0), [a1] "+r"(a1), [a2] "+r"(a2), [a3] "+r"(a3), [k] "+r"(k),
                      [xp] "+r"(xp), [x0] "=&r"(x0), [x1] "=&r"(x1), [w0] "=&r"(w0),
                      [w1] "=&r"(w1), [t] "=&r"(t)
                    :
                    : "memory");
        }
        if (n_pairs & 1u) {
            const int32_t xv = rd2(xp);
            uint32_t v0, v1;
            __builtin_memcpy(&v0, k, 4);
            __builtin_memcpy(&v1, k + 4, 4);
            a0 = __smlad(__sxtb16((int8x4_t)v0), xv, a0);
            a1 = __smlad(__sxtb16((int8x4_t)(v0 >> 8 | v0 << 24)), xv, a1);
            a2 = __smlad(__sxtb16((int8x4_t)v1), xv, a2);
            a3 = __smlad(__sxtb16((int8x4_t)(v1 >> 8 | v1 << 24)), xv, a3);
            k += 8;
        }
        acc[j] = a0, acc[j + 1u] = a1, acc[j + 2u] = a2, acc[j + 3u] = a3;
    }
    if (j < n_rows)
        rows_s8_dsp(k, x, n_pairs, n_rows - j, acc + j);
}

#endif /* the sums where there is no Helium */

/* cn_spdot_s16_c's sums: per row its count, then two entries a step (LDRD; the inputs'
 * byte offsets by LSR from the high halves; two LDRSH; SMLABB of each entry's low half,
 * its latent, with the input: seven instructions and the loop's two). */
uint32_t cn_spdot_s16_dsp(const uint32_t *e, const int16_t *x, uint32_t n_rows, int32_t *acc)
{
    uint32_t total = 0;
    for (uint32_t j = 0; j < n_rows; j++) {
        const uint32_t n = *e++;
        total += n;
        int32_t a = 0;
        if (n >= 2u) {
            const uint32_t *end = e + (n & ~1u);
            uint32_t w0, w1, i0, i1;
            __asm__("1:\n\t"
                    "ldrd %[w0], %[w1], [%[e]], #8\n\t"
                    "lsr %[i0], %[w0], #16\n\t"
                    "lsr %[i1], %[w1], #16\n\t"
                    "ldrsh %[i0], [%[x], %[i0]]\n\t"
                    "ldrsh %[i1], [%[x], %[i1]]\n\t"
                    "smlabb %[a], %[w0], %[i0], %[a]\n\t"
                    "smlabb %[a], %[w1], %[i1], %[a]\n\t"
                    "cmp %[e], %[end]\n\t"
                    "bne 1b"
                    : [a] "+r"(a), [e] "+r"(e), [w0] "=&r"(w0), [w1] "=&r"(w1), [i0] "=&r"(i0),
                      [i1] "=&r"(i1)
                    : [x] "r"(x), [end] "r"(end)
                    : "cc", "memory");
        }
        if (n & 1u) {
            const uint32_t w = *e++;
            a = __smlabb((int32_t)w, x[w >> 17], a);
        }
        acc[j] = a;
    }
    return total;
}

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

void cn_finish_s32_dsp(const int32_t *acc, uint32_t live, int32_t am, unsigned n, int32_t t,
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

/* A layer's inputs at its scale for 1 <= s <= 16 (render.c's requant: sat16 of x plus
 * 2^(s-1) saturated, shifted right by s), two at a time: one LDRD, two QADDs, two shifts,
 * two SSATs, one PKHBT packing the pair, one store, and one SMLAD with (1, 1) adding both
 * to the sum. Returns the sum. */
int32_t cn_requant_s16_dsp(const int32_t *x, int16_t *xq, uint32_t n, unsigned s)
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
#else
typedef int cn_no_dsp; /* ISO C: a translation unit declares something */
#endif
