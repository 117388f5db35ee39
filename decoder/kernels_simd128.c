/*
 * WebAssembly's 128-bit SIMD (wasm32 with simd128): cn_dot_s16_simd128 and cn_dot_s8_simd128,
 * exactly cn_dot_s16_c's and cn_dot_s8_c's sums (cn_kernels.h; int8 latents widened by
 * i16x8.load8x8_s): per block of four rows and input pair, one load of the
 * block's eight latents (layout CN_PAIRS) and one i32x4.dot_i16x8_s with the pair splat to
 * the four lanes (once per call), which sums each row's two products into its lane; four
 * (then two) blocks a step share each load of the splat pair; the last one to three rows
 * eight latents of a row a step. The sums wrap modulo
 * 2^32 like the C's int32 sums, and the caller's bound makes them exact. Also
 * cn_requant_s16_simd128 and cn_finish_s32_simd128, render.c's input quantization and output
 * rescale.
 */
#include "../common/cn_fixed.h"
#include "cn_kernels.h"
#include "cnerf/format.h"

#if defined(CN_HAVE_SIMD128)
#include <wasm_simd128.h>

/* The shift count s for a shift by a count held in a variable inside a loop: the
 * instructions take it as a scalar (i32x4.shr_s and the others), but clang 14 hoists the
 * count's splat out of the loop and then, seeing a vector count, shifts lane by lane. The
 * empty asm, volatile, stays in the loop and gives a value the compiler cannot hoist. */
static inline unsigned in_loop(unsigned s)
{
    __asm__ volatile("" : "+r"(s));
    return s;
}

/* A pair's eight latents of a block as int16 lanes (int8 widened by the load). */
static inline v128_t pair_s16(const int16_t *k) { return wasm_v128_load(k); }
static inline v128_t pair_s8(const int8_t *k) { return wasm_i16x8_load8x8(k); }

/* The last one to three rows, each row's latents in turn (cn_kernels.h): eight of a row
 * against eight inputs a step (i32x4.dot_i16x8_s), the four lanes added at the end, then the
 * inputs past the last multiple of eight. The same int32 sums as the C's row by row. */
#define CN_ROWS_SIMD128(NAME, KT, EIGHT)                                                    \
    static void NAME(const KT *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,      \
                     int32_t *acc)                                                          \
    {                                                                                       \
        const uint32_t n = 2u * n_pairs;                                                    \
        for (uint32_t j = 0; j < n_rows; j++, k += n) {                                     \
            v128_t a = wasm_i32x4_splat(0);                                                 \
            uint32_t i = 0;                                                                 \
            for (; i + 8u <= n; i += 8u)                                                    \
                a = wasm_i32x4_add(a, wasm_i32x4_dot_i16x8(EIGHT(k + i), wasm_v128_load(x + i))); \
            int32_t sum = (int32_t)((uint32_t)wasm_i32x4_extract_lane(a, 0) +               \
                                    (uint32_t)wasm_i32x4_extract_lane(a, 1) +               \
                                    (uint32_t)wasm_i32x4_extract_lane(a, 2) +               \
                                    (uint32_t)wasm_i32x4_extract_lane(a, 3));               \
            for (; i < n; i++)                                                              \
                sum += (int32_t)k[i] * x[i];                                                \
            acc[j] = sum;                                                                   \
        }                                                                                   \
    }

CN_ROWS_SIMD128(rows_s16, int16_t, pair_s16)
CN_ROWS_SIMD128(rows_s8, int8_t, pair_s8)

#define CN_DOT_SIMD128(NAME, KT, PAIR, TAIL)                                                \
    void NAME(const KT *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows, int32_t *acc) \
    {                                                                                       \
        /* the pairs splat to four lanes once per call (on the stack: at most 282 vectors) */ \
        v128_t xs[(CNERF_MAX_LAYER_IN + 1u) / 2u];                                          \
        for (uint32_t p = 0; p < n_pairs; p++)                                              \
            xs[p] = wasm_v128_load32_splat(x + 2u * p);                                     \
        const uint32_t block = 8u * n_pairs; /* latents of a block of four rows */          \
        uint32_t j = 0;                                                                     \
        for (; j + 16u <= n_rows; j += 16u, k += 4u * block) { /* four blocks a load of xs */ \
            v128_t a = wasm_i32x4_splat(0), b = a, c = a, d = a;                            \
            const KT *k1 = k + block, *k2 = k + 2u * block, *k3 = k + 3u * block;           \
            for (uint32_t p = 0; p < n_pairs; p++) {                                        \
                const v128_t xp = xs[p];                                                    \
                a = wasm_i32x4_add(a, wasm_i32x4_dot_i16x8(PAIR(k + 8u * p), xp));          \
                b = wasm_i32x4_add(b, wasm_i32x4_dot_i16x8(PAIR(k1 + 8u * p), xp));         \
                c = wasm_i32x4_add(c, wasm_i32x4_dot_i16x8(PAIR(k2 + 8u * p), xp));         \
                d = wasm_i32x4_add(d, wasm_i32x4_dot_i16x8(PAIR(k3 + 8u * p), xp));         \
            }                                                                               \
            wasm_v128_store(acc + j, a);                                                    \
            wasm_v128_store(acc + j + 4u, b);                                               \
            wasm_v128_store(acc + j + 8u, c);                                               \
            wasm_v128_store(acc + j + 12u, d);                                              \
        }                                                                                   \
        for (; j + 8u <= n_rows; j += 8u, k += 2u * block) { /* two blocks: one load of xs each */ \
            v128_t a = wasm_i32x4_splat(0), b = wasm_i32x4_splat(0);                        \
            const KT *k1 = k + block;                                                       \
            for (uint32_t p = 0; p < n_pairs; p++) {                                        \
                a = wasm_i32x4_add(a, wasm_i32x4_dot_i16x8(PAIR(k + 8u * p), xs[p]));       \
                b = wasm_i32x4_add(b, wasm_i32x4_dot_i16x8(PAIR(k1 + 8u * p), xs[p]));      \
            }                                                                               \
            wasm_v128_store(acc + j, a);                                                    \
            wasm_v128_store(acc + j + 4u, b);                                               \
        }                                                                                   \
        if (j + 4u <= n_rows) {                                                             \
            v128_t a = wasm_i32x4_splat(0);                                                 \
            for (uint32_t p = 0; p < n_pairs; p++)                                          \
                a = wasm_i32x4_add(a, wasm_i32x4_dot_i16x8(PAIR(k + 8u * p), xs[p]));       \
            wasm_v128_store(acc + j, a);                                                    \
            j += 4u;                                                                        \
            k += block;                                                                     \
        }                                                                                   \
        if (j < n_rows)                                                                     \
            TAIL(k, x, n_pairs, n_rows - j, acc + j);                                       \
    }

CN_DOT_SIMD128(cn_dot_s16_simd128, int16_t, pair_s16, rows_s16)
CN_DOT_SIMD128(cn_dot_s8_simd128, int8_t, pair_s8, rows_s8)

/* render.c's requant for 1 <= s <= 16, eight inputs a step: floor(x / 2^s + 1/2) as
 * (x >> s) plus bit s - 1 of x (no addition that could overflow: the same value as the C's
 * saturated x + 2^(s-1) shifted, which saturates only where both give 32767), narrowed with
 * signed saturation (i16x8.narrow_i32x4_s: sat16), the sum by i32x4.dot_i16x8_s with ones. */
int32_t cn_requant_s16_simd128(const int32_t *x, int16_t *xq, uint32_t n, unsigned s)
{
    const v128_t one = wasm_i32x4_splat(1), ones16 = wasm_i16x8_splat(1);
    v128_t sum = wasm_i32x4_splat(0);
    uint32_t i = 0;
    for (; i + 8u <= n; i += 8u) {
        const unsigned sh = in_loop(s), sh1 = in_loop(s - 1u);
        const v128_t a = wasm_v128_load(x + i), b = wasm_v128_load(x + i + 4u);
        const v128_t qa = wasm_i32x4_add(wasm_i32x4_shr(a, sh),
                                         wasm_v128_and(wasm_u32x4_shr(a, sh1), one));
        const v128_t qb = wasm_i32x4_add(wasm_i32x4_shr(b, sh),
                                         wasm_v128_and(wasm_u32x4_shr(b, sh1), one));
        const v128_t q = wasm_i16x8_narrow_i32x4(qa, qb);
        wasm_v128_store(xq + i, q);
        sum = wasm_i32x4_add(sum, wasm_i32x4_dot_i16x8(q, ones16));
    }
    int32_t r = wasm_i32x4_extract_lane(sum, 0) + wasm_i32x4_extract_lane(sum, 1) +
                wasm_i32x4_extract_lane(sum, 2) + wasm_i32x4_extract_lane(sum, 3);
    for (; i < n; i++) { /* the last inputs as the vector steps do them */
        xq[i] = cn_requant16(x[i], s);
        r += xq[i];
    }
    return r;
}

/* sat32(a + b) in four lanes: on overflow (a and b of one sign, the sum of the other) the
 * bound of a's sign. */
static inline v128_t qadd_simd128(v128_t a, v128_t b)
{
    const v128_t r = wasm_i32x4_add(a, b);
    const v128_t ov = wasm_i32x4_shr(wasm_v128_and(wasm_v128_xor(a, r), wasm_v128_xor(b, r)), 31);
    const v128_t sat = wasm_v128_xor(wasm_i32x4_shr(a, 31), wasm_i32x4_splat(0x7FFFFFFF));
    return wasm_v128_bitselect(sat, r, ov);
}

/* render.c's finish_fast for n < 32, four outputs a step: the products acc am in 64-bit
 * lanes (i64x2.extmul_low/high_i32x4_s), plus 2^(n-1), shifted right by n (the low word of
 * each lane is the result: bits n..n+31 of the sum, as the C's), then the two saturating
 * additions and, for relu, max(0, .). The additions are made wrapping first, and made again
 * saturating only when one of the four lanes wrapped (i32x4.bitmask of the overflow test):
 * the same values, for less work where nothing saturates. */
void cn_finish_s32_simd128(const int32_t *acc, uint32_t live, int32_t am, unsigned n, int32_t t,
                           const int32_t *bq, int32_t *y, int relu)
{
    const v128_t amv = wasm_i32x4_splat(am), tv = wasm_i32x4_splat(t);
    const v128_t half = wasm_i64x2_splat((int64_t)1 << (n - 1u)), zero = wasm_i32x4_splat(0);
    uint32_t j = 0;
    for (; j + 4u <= live; j += 4u) {
        const unsigned sh = in_loop(n);
        const v128_t a = wasm_v128_load(acc + j);
        const v128_t lo = wasm_u64x2_shr(wasm_i64x2_add(wasm_i64x2_extmul_low_i32x4(a, amv), half), sh);
        const v128_t hi = wasm_u64x2_shr(wasm_i64x2_add(wasm_i64x2_extmul_high_i32x4(a, amv), half), sh);
        const v128_t r = wasm_i32x4_shuffle(lo, hi, 0, 2, 4, 6), b = wasm_v128_load(bq + j);
        const v128_t r1 = wasm_i32x4_add(r, tv), r2 = wasm_i32x4_add(r1, b);
        /* the two additions wrapped where the sign bit of this is set: then saturate */
        const v128_t ov = wasm_v128_or(wasm_v128_and(wasm_v128_xor(r, r1), wasm_v128_xor(tv, r1)),
                                       wasm_v128_and(wasm_v128_xor(r1, r2), wasm_v128_xor(b, r2)));
        v128_t v = wasm_i32x4_bitmask(ov) ? qadd_simd128(qadd_simd128(r, tv), b) : r2;
        if (relu)
            v = wasm_i32x4_max(v, zero);
        wasm_v128_store(y + j, v);
    }
    for (; j < live; j++) {
        const uint64_t u = (uint64_t)((int64_t)acc[j] * am) + ((uint64_t)1 << (n - 1u));
        const int32_t v = cn_qadd32(cn_qadd32(cn_s32((uint32_t)(u >> n)), t), bq[j]);
        y[j] = relu && v < 0 ? 0 : v;
    }
}
#else
typedef int cn_no_simd128; /* ISO C: a translation unit declares something */
#endif
