/*
 * Advanced SIMD (aarch64): cn_dot_s16_neon, exactly cn_dot_s16_c's sums (cn_kernels.h): per
 * block of four rows and input pair, one 128-bit load of the latents and two widening
 * multiply-accumulates (vmlal_s16, vmlal_high_s16) into two rows each.
 */
#include "cn_kernels.h"

#if defined(CN_HAVE_NEON)
#include <arm_neon.h>

void cn_dot_s16_neon(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
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
        cn_dot_s16_c(k, x, n_pairs, n_rows - j, acc + j);
}
#else
typedef int cn_no_neon; /* ISO C: a translation unit declares something */
#endif
