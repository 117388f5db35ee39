/*
 * Advanced SIMD (aarch64): cn_dot_s16_neon and cn_dot_s8_neon, exactly cn_dot_s16_c's and
 * cn_dot_s8_c's sums (cn_kernels.h): per block of four rows and input pair, one load of the
 * latents (int8 widened by vmovl_s8) and two widening multiply-accumulates (vmlal_s16,
 * vmlal_high_s16) into two rows each.
 */
#include "cn_kernels.h"

#if defined(CN_HAVE_NEON)
#include <arm_neon.h>

/* A pair's eight latents of a block as int16 lanes. */
static inline int16x8_t pair_s16(const int16_t *k) { return vld1q_s16(k); }
static inline int16x8_t pair_s8(const int8_t *k) { return vmovl_s8(vld1_s8(k)); }

#define CN_DOT_NEON(NAME, KT, PAIR, TAIL)                                                   \
    void NAME(const KT *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows, int32_t *acc) \
    {                                                                                       \
        uint32_t j = 0;                                                                     \
        for (; j + 4u <= n_rows; j += 4u) {                                                 \
            int32x4_t lo = vdupq_n_s32(0), hi = vdupq_n_s32(0);                             \
            for (uint32_t p = 0; p < n_pairs; p++, k += 8) {                                \
                int32_t xv;                                                                 \
                __builtin_memcpy(&xv, x + 2u * p, 4);                                       \
                const int16x8_t xx = vreinterpretq_s16_s32(vdupq_n_s32(xv));                \
                const int16x8_t w = PAIR(k);                                                \
                lo = vmlal_s16(lo, vget_low_s16(w), vget_low_s16(xx)); /* rows 0, 1 */      \
                hi = vmlal_high_s16(hi, w, xx);                         /* rows 2, 3 */     \
            }                                                                               \
            vst1q_s32(acc + j, vpaddq_s32(lo, hi));                                         \
        }                                                                                   \
        if (j < n_rows)                                                                     \
            TAIL(k, x, n_pairs, n_rows - j, acc + j);                                       \
    }

CN_DOT_NEON(cn_dot_s16_neon, int16_t, pair_s16, cn_dot_s16_c)
CN_DOT_NEON(cn_dot_s8_neon, int8_t, pair_s8, cn_dot_s8_c)
#else
typedef int cn_no_neon; /* ISO C: a translation unit declares something */
#endif
