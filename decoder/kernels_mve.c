/*
 * Helium (the M-profile vector extension: Cortex-M55, M85): cn_dot_s16_mve and cn_dot_s8_mve,
 * exactly cn_dot_s16_c's and cn_dot_s8_c's sums over latents packed in layout CN_RUNS8 (int8
 * widened by their loads, VLDRB.S16), and cn_requant_s16_mve and
 * cn_finish_s32_mve, exactly render.c's input quantization and output rescale
 * (cn_kernels.h). The lists of non-zero latents keep the DSP extension's kernel.
 */
#include "../common/cn_fixed.h"
#include "cn_kernels.h"

#if defined(CN_HAVE_MVE)
#include <arm_mve.h>

/* A block of four rows, run by run of eight inputs: one load of the run's inputs, then per
 * row one load of its eight latents and one VMLADAVA (eight products summed into the row's
 * accumulator; the sum is exact modulo 2^32, and the caller's int32 bound makes it the
 * sum). Where the inputs are whole runs (a multiple of eight), every block is one loop
 * in assembly: nine instructions and the low-overhead loop's LE per run, every load
 * writing its pointer back, VMLADAVA's accumulators in even registers (constraint Te), and
 * eight instructions a block around it. Otherwise a last run of m < 8 inputs loads m lanes (the
 * others zero: a predicated load reads nothing past them). The last one to three rows,
 * row after row, the same way.
 * One run of a block: the run's inputs, then each row's eight latents (LDK: one load,
 * widening int8 to int16 lanes for int8 latents) and its VMLADAVA. */
#define CN_MVE_RUN(LDK)                                                                     \
    "vldrh.16 %q[xv], [%[xp]], #16\n\t"                                                     \
    LDK(w0) LDK(w1)                                                                         \
    "vmladava.s16 %[a0], %q[w0], %q[xv]\n\t"                                                \
    LDK(w0)                                                                                 \
    "vmladava.s16 %[a1], %q[w1], %q[xv]\n\t"                                                \
    LDK(w1)                                                                                 \
    "vmladava.s16 %[a2], %q[w0], %q[xv]\n\t"                                                \
    "vmladava.s16 %[a3], %q[w1], %q[xv]\n\t"
#define CN_LDK_S16(w) "vldrh.16 %q[" #w "], [%[k]], #16\n\t"
#define CN_LDK_S8(w) "vldrb.s16 %q[" #w "], [%[k]], #8\n\t"

/* A run's eight latents as int16 lanes, and the first m of them (the others zero). */
static inline int16x8_t run_s16(const int16_t *k) { return vld1q_s16(k); }
static inline int16x8_t run_s8(const int8_t *k) { return vldrbq_s16(k); }
static inline int16x8_t part_s16(const int16_t *k, mve_pred16_t p) { return vldrhq_z_s16(k, p); }
static inline int16x8_t part_s8(const int8_t *k, mve_pred16_t p) { return vldrbq_z_s16(k, p); }

#define CN_DOT_MVE(NAME, KT, LDK, RUN, PART)                                                \
    void NAME(const KT *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows, int32_t *acc) \
    {                                                                                       \
        const uint32_t runs = (2u * n_pairs) >> 3, left = (2u * n_pairs) & 7u;              \
        const mve_pred16_t p = vctp16q(left);                                               \
        uint32_t j = 0;                                                                     \
        if (!left && runs && n_rows >= 4u) {                                                \
            uint32_t blocks = n_rows >> 2;                                                  \
            register uint32_t r __asm__("lr"); /* the low-overhead loop's count (DLS, LE) */ \
            int32_t a0, a1, a2, a3;                                                         \
            const int16_t *xp;                                                              \
            int16x8_t xv, w0, w1;                                                           \
            j = 4u * blocks;                                                                \
            __asm__("2:\n\t"                                                                \
                    "mov %[a0], #0\n\t"                                                     \
                    "mov %[a1], #0\n\t"                                                     \
                    "mov %[a2], #0\n\t"                                                     \
                    "mov %[a3], #0\n\t"                                                     \
                    "mov %[xp], %[x]\n\t"                                                   \
                    "dls lr, %[runs]\n\t"                                                   \
                    "1:\n\t" CN_MVE_RUN(LDK) "le lr, 1b\n\t"                                \
                    "strd %[a0], %[a1], [%[acc]], #8\n\t"                                   \
                    "strd %[a2], %[a3], [%[acc]], #8\n\t"                                   \
                    "subs %[b], %[b], #1\n\t"                                               \
                    "bne 2b"                                                                \
                    : [a0] "=&Te"(a0), [a1] "=&Te"(a1), [a2] "=&Te"(a2), [a3] "=&Te"(a3),   \
                      [k] "+r"(k), [acc] "+r"(acc), [b] "+r"(blocks), [xp] "=&r"(xp),       \
                      [r] "=&r"(r), [xv] "=&w"(xv), [w0] "=&w"(w0), [w1] "=&w"(w1)          \
                    : [x] "r"(x), [runs] "r"(runs)                                          \
                    : "cc", "memory");                                                      \
            acc -= j; /* acc[j] is the next row's again */                                  \
        }                                                                                   \
        for (; j + 4u <= n_rows; j += 4u) {                                                 \
            int32_t a0 = 0, a1 = 0, a2 = 0, a3 = 0;                                         \
            const int16_t *xp = x;                                                          \
            for (uint32_t r = runs; r > 0u; r--) {                                          \
                const int16x8_t xv = vld1q_s16(xp);                                         \
                xp += 8;                                                                    \
                a0 = vmladavaq_s16(a0, RUN(k), xv);                                         \
                a1 = vmladavaq_s16(a1, RUN(k + 8), xv);                                     \
                a2 = vmladavaq_s16(a2, RUN(k + 16), xv);                                    \
                a3 = vmladavaq_s16(a3, RUN(k + 24), xv);                                    \
                k += 32;                                                                    \
            }                                                                               \
            if (left) {                                                                     \
                const int16x8_t xv = vldrhq_z_s16(xp, p);                                   \
                a0 = vmladavaq_s16(a0, PART(k, p), xv);                                     \
                a1 = vmladavaq_s16(a1, PART(k + left, p), xv);                              \
                a2 = vmladavaq_s16(a2, PART(k + 2u * left, p), xv);                         \
                a3 = vmladavaq_s16(a3, PART(k + 3u * left, p), xv);                         \
                k += 4u * left;                                                             \
            }                                                                               \
            acc[j] = a0, acc[j + 1u] = a1, acc[j + 2u] = a2, acc[j + 3u] = a3;              \
        }                                                                                   \
        for (; j < n_rows; j++) {                                                           \
            int32_t a = 0;                                                                  \
            const int16_t *xp = x;                                                          \
            for (uint32_t r = runs; r > 0u; r--, k += 8, xp += 8)                           \
                a = vmladavaq_s16(a, RUN(k), vld1q_s16(xp));                                \
            if (left) {                                                                     \
                a = vmladavaq_s16(a, PART(k, p), vldrhq_z_s16(xp, p));                      \
                k += left;                                                                  \
            }                                                                               \
            acc[j] = a;                                                                     \
        }                                                                                   \
    }

CN_DOT_MVE(cn_dot_s16_mve, int16_t, CN_LDK_S16, run_s16, part_s16)
CN_DOT_MVE(cn_dot_s8_mve, int8_t, CN_LDK_S8, run_s8, part_s8)

/* render.c's requant for 1 <= s <= 16, eight inputs a step (ten instructions with the
 * loop's two): VLD20/VLD21 split them into the even and the odd ones (q0, q1); VRSHL by -s
 * gives floor(x / 2^s + 1/2) exactly (the rounding constant is added before the shift
 * without overflow, which differs from the saturating add only where both saturate to
 * 32767 below); VQMOVNB and VQMOVNT saturate them to int16 into the even and the odd
 * lanes of one vector, which is the eight in order; VADDVA adds them to the sum. The last
 * n % 8 as render.c does. */
int32_t cn_requant_s16_mve(const int32_t *x, int16_t *xq, uint32_t n, unsigned s)
{
    const int32_t down = -(int32_t)s, h = (int32_t)1 << (s - 1u);
    int32_t sum = 0;
    uint32_t steps = n >> 3;
    if (steps) {
        int16x8_t q;
        __asm__("1:\n\t"
                "vld20.32 {q0, q1}, [%[x]]\n\t"
                "vld21.32 {q0, q1}, [%[x]]!\n\t"
                "vrshl.s32 q0, %[down]\n\t"
                "vrshl.s32 q1, %[down]\n\t"
                "vqmovnb.s32 %q[q], q0\n\t"
                "vqmovnt.s32 %q[q], q1\n\t"
                "vstrh.16 %q[q], [%[xq]], #16\n\t"
                "vaddva.s16 %[sum], %q[q]\n\t"
                "subs %[steps], %[steps], #1\n\t"
                "bne 1b"
                : [sum] "+Te"(sum), [x] "+r"(x), [xq] "+r"(xq), [steps] "+r"(steps),
                  [q] "=&w"(q)
                : [down] "r"(down)
                : "cc", "memory", "d0", "d1", "d2", "d3");
    }
    for (n &= 7u; n > 0u; n--) {
        const int32_t v = cn_sat16(cn_asr32(cn_qadd32(*x++, h), s));
        *xq++ = (int16_t)v;
        sum += v;
    }
    return sum;
}

/* render.c's finish_fast for 1 <= n < 32, four outputs a step, then the two saturating
 * additions (VQADD) and ReLU as a maximum with 0 (or with INT32_MIN: none); the last
 * live % 4 outputs by predicated loads and a predicated store. The rescale r =
 * floor(P / 2^n + 1/2) of P = acc a_m, where cnerf_open proved |r| < 2^30, two ways:
 * - |a_m| < 2^n: VQRDMULH by a_m 2^(31-n) (below 2^31 in magnitude) is
 *   (2 acc a_m 2^(31-n) + 2^31) >> 32, which is r, formed without overflow and not
 *   saturated (|r| < 2^30); nine instructions with the loop's two;
 * - otherwise: Q = floor(P / 2^(n-1)) lies in the int32 range and r = floor((Q + 1) / 2):
 *   VMUL gives P's low word and VMULH its high word, Q is the low word shifted right by
 *   n - 1 with the high word's bits shifted in from the left by 33 - n, and VRSHR #1
 *   rounds it; fourteen instructions. n = 1, where that shift would be 32, takes the
 *   scalar loop. */
static inline int32x4_t rescale4(int32x4_t a, int32x4_t m, int32_t down, int32_t up)
{
    const uint32x4_t lo = vreinterpretq_u32_s32(vmulq_s32(a, m));
    const uint32x4_t hi = vreinterpretq_u32_s32(vmulhq_s32(a, m));
    const uint32x4_t q = vorrq_u32(vshlq_r_u32(lo, down), vshlq_r_u32(hi, up));
    return vrshrq_n_s32(vreinterpretq_s32_u32(q), 1);
}

void cn_finish_s32_mve(const int32_t *acc, uint32_t live, int32_t am, unsigned n, int32_t t,
                       const int32_t *bq, int32_t *y, int relu)
{
    const int32x4_t floor = vdupq_n_s32(relu ? 0 : INT32_MIN);
    const uint32_t mag = (uint32_t)(am < 0 ? -(int64_t)am : am);
    uint32_t steps = live >> 2;
    int32x4_t a, b;
    if (mag < ((uint32_t)1 << n)) {
        const int32_t m = (int32_t)((uint32_t)am << (31u - n));
        if (steps)
            __asm__("1:\n\t"
                    "vldrw.32 %q[a], [%[acc]], #16\n\t"
                    "vldrw.32 %q[b], [%[bq]], #16\n\t"
                    "vqrdmulh.s32 %q[a], %q[a], %[m]\n\t"
                    "vqadd.s32 %q[a], %q[a], %[t]\n\t"
                    "vqadd.s32 %q[a], %q[a], %q[b]\n\t"
                    "vmax.s32 %q[a], %q[a], %q[floor]\n\t"
                    "vstrw.32 %q[a], [%[y]], #16\n\t"
                    "subs %[steps], %[steps], #1\n\t"
                    "bne 1b"
                    : [acc] "+r"(acc), [bq] "+r"(bq), [y] "+r"(y), [steps] "+r"(steps),
                      [a] "=&w"(a), [b] "=&w"(b)
                    : [m] "r"(m), [t] "r"(t), [floor] "w"(floor)
                    : "cc", "memory");
        if (live & 3u) {
            const mve_pred16_t p = vctp32q(live & 3u);
            a = vqrdmulhq_n_s32(vldrwq_z_s32(acc, p), m);
            a = vqaddq_s32(vqaddq_n_s32(a, t), vldrwq_z_s32(bq, p));
            vstrwq_p_s32(y, vmaxq_s32(a, floor), p);
        }
        return;
    }
    if (n == 1u) {
        for (uint32_t j = 0; j < live; j++) {
            const int32_t v = cn_qadd32(cn_qadd32(cn_rescale_fast(acc[j], am, 1u, 1u), t), bq[j]);
            y[j] = relu && v < 0 ? 0 : v;
        }
        return;
    }
    const int32_t down = -(int32_t)(n - 1u), up = (int32_t)(33u - n);
    const int32x4_t m = vdupq_n_s32(am);
    if (steps) {
        int32x4_t c;
        __asm__("1:\n\t"
                "vldrw.32 %q[a], [%[acc]], #16\n\t"
                "vmul.i32 %q[b], %q[a], %q[m]\n\t"
                "vmulh.s32 %q[a], %q[a], %q[m]\n\t"
                "vshl.u32 %q[b], %[down]\n\t"
                "vshl.u32 %q[a], %[up]\n\t"
                "vorr %q[b], %q[b], %q[a]\n\t"
                "vrshr.s32 %q[b], %q[b], #1\n\t"
                "vldrw.32 %q[c], [%[bq]], #16\n\t"
                "vqadd.s32 %q[b], %q[b], %[t]\n\t"
                "vqadd.s32 %q[b], %q[b], %q[c]\n\t"
                "vmax.s32 %q[b], %q[b], %q[floor]\n\t"
                "vstrw.32 %q[b], [%[y]], #16\n\t"
                "subs %[steps], %[steps], #1\n\t"
                "bne 1b"
                : [acc] "+r"(acc), [bq] "+r"(bq), [y] "+r"(y), [steps] "+r"(steps),
                  [a] "=&w"(a), [b] "=&w"(b), [c] "=&w"(c)
                : [m] "w"(m), [down] "r"(down), [up] "r"(up), [t] "r"(t), [floor] "w"(floor)
                : "cc", "memory");
    }
    if (live & 3u) {
        const mve_pred16_t p = vctp32q(live & 3u);
        a = vqaddq_n_s32(rescale4(vldrwq_z_s32(acc, p), m, down, up), t);
        vstrwq_p_s32(y, vmaxq_s32(vqaddq_s32(a, vldrwq_z_s32(bq, p)), floor), p);
    }
}
#else
typedef int cn_no_mve; /* ISO C: a translation unit declares something */
#endif
