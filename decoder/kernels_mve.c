/*
 * Helium (the M-profile vector extension: Cortex-M55, M85): cn_dot_s16_mve, exactly
 * cn_dot_s16_c's sums (cn_kernels.h). The inputs' quantization and the outputs' rescale are
 * the DSP extension's (dsp.c).
 */
#include "cn_kernels.h"

#if defined(CN_HAVE_MVE)
#include <arm_mve.h>

/* Each vector holds one input pair of the block's four rows; multiplied lane by lane with
 * the pair repeated four times, the bottom (even) lanes give k[r][2p] x[2p] and the top
 * (odd) lanes k[r][2p+1] x[2p+1], both as four int32. Two pairs a step, into two
 * accumulators. */
void cn_dot_s16_mve(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
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
        cn_dot_s16_c(k, x, n_pairs, n_rows - j, acc + j);
}
#else
typedef int cn_no_mve; /* ISO C: a translation unit declares something */
#endif
