/*
 * x86-64 kernels, chosen at run time (kernels.c): AVX2 (vpmaddwd: sixteen 16-bit products
 * summed in pairs into eight int32) when the CPU has it and the operating system saves its
 * registers (cn_cpu_has_avx2). cn_dot_s16_avx2 and cn_dot_s8_avx2 compute exactly
 * cn_dot_s16_c's and cn_dot_s8_c's sums,
 * cn_requant_s16_avx2 and cn_finish_s32_avx2 render.c's input quantization and output
 * rescale (cn_kernels.h). Each function carries its target, so the file builds with the
 * compiler's default flags.
 */
#include "../common/cn_fixed.h"
#include "cn_kernels.h"
#include "cnerf/format.h"

#if defined(CN_HAVE_AVX2)
#include <cpuid.h>
#include <immintrin.h>

/* Latents as int16 lanes: sixteen (a 256-bit vector) and eight (128 bits), loaded as they
 * are (int16) or widened by vpmovsxbw from sixteen and eight bytes (int8). */
__attribute__((target("avx2"))) static inline __m256i k16_s16(const int16_t *k)
{
    return _mm256_loadu_si256((const __m256i *)(const void *)k);
}
__attribute__((target("avx2"))) static inline __m128i k8_s16(const int16_t *k)
{
    return _mm_loadu_si128((const __m128i *)(const void *)k);
}
__attribute__((target("avx2"))) static inline __m256i k16_s8(const int8_t *k)
{
    return _mm256_cvtepi8_epi16(_mm_loadu_si128((const __m128i *)(const void *)k));
}
__attribute__((target("avx2"))) static inline __m128i k8_s8(const int8_t *k)
{
    return _mm_cvtepi8_epi16(_mm_loadl_epi64((const __m128i *)(const void *)k));
}

/* Each 256-bit vector of latents holds two input pairs of the block's four rows; multiplied
 * with the first pair repeated in the low half and the second in the high half, vpmaddwd
 * gives the four rows' sums over each pair. The inputs are spread that way once per call
 * (xx, on the stack: at most 281 vectors), so a block's step is a load, a vpmaddwd and an
 * add. The last one to three rows, row after row: sixteen inputs per vpmaddwd (ROW). */
#define CN_DOT_AVX2(NAME, ROW, KT, K16, K8)                                                 \
    __attribute__((target("avx2"))) static int32_t ROW(const KT *k, const int16_t *x,        \
                                                       uint32_t n)                          \
    {                                                                                       \
        __m256i a = _mm256_setzero_si256();                                                 \
        uint32_t i = 0;                                                                     \
        for (; i + 16u <= n; i += 16u)                                                      \
            a = _mm256_add_epi32(                                                           \
                a, _mm256_madd_epi16(K16(k + i),                                            \
                                     _mm256_loadu_si256((const __m256i *)(const void *)(x + i)))); \
        __m128i s = _mm_add_epi32(_mm256_castsi256_si128(a), _mm256_extracti128_si256(a, 1)); \
        for (; i + 8u <= n; i += 8u)                                                        \
            s = _mm_add_epi32(                                                              \
                s, _mm_madd_epi16(K8(k + i), _mm_loadu_si128((const __m128i *)(const void *)(x + i)))); \
        s = _mm_add_epi32(s, _mm_shuffle_epi32(s, 0x4E));                                   \
        s = _mm_add_epi32(s, _mm_shuffle_epi32(s, 0xB1));                                   \
        int32_t r = _mm_cvtsi128_si32(s);                                                   \
        for (; i < n; i++)                                                                  \
            r += k[i] * x[i];                                                               \
        return r;                                                                           \
    }                                                                                       \
    __attribute__((target("avx2"))) void NAME(const KT *k, const int16_t *x, uint32_t n_pairs, \
                                              uint32_t n_rows, int32_t *acc)                \
    {                                                                                       \
        __m256i xx[(CNERF_MAX_LAYER_IN + 3u) / 4u];                                         \
        const __m256i spread = _mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1);                   \
        const uint32_t steps = n_pairs >> 1;                                                \
        for (uint32_t q = 0; q < steps; q++)                                                \
            xx[q] = _mm256_permutevar8x32_epi32(                                            \
                _mm256_castsi128_si256(                                                     \
                    _mm_loadl_epi64((const __m128i *)(const void *)(x + 4u * q))),          \
                spread);                                                                    \
        int32_t xlast = 0;                                                                  \
        if (n_pairs & 1u)                                                                   \
            __builtin_memcpy(&xlast, x + 4u * steps, 4);                                    \
        uint32_t j = 0;                                                                     \
        for (; j + 4u <= n_rows; j += 4u) {                                                 \
            __m256i a = _mm256_setzero_si256(), b = _mm256_setzero_si256();                 \
            uint32_t q = 0;                                                                 \
            for (; q + 2u <= steps; q += 2u, k += 32) {                                     \
                a = _mm256_add_epi32(a, _mm256_madd_epi16(K16(k), xx[q]));                  \
                b = _mm256_add_epi32(b, _mm256_madd_epi16(K16(k + 16), xx[q + 1u]));        \
            }                                                                               \
            if (q < steps) {                                                                \
                a = _mm256_add_epi32(a, _mm256_madd_epi16(K16(k), xx[q]));                  \
                k += 16;                                                                    \
            }                                                                               \
            a = _mm256_add_epi32(a, b);                                                     \
            __m128i s =                                                                     \
                _mm_add_epi32(_mm256_castsi256_si128(a), _mm256_extracti128_si256(a, 1));   \
            if (n_pairs & 1u) {                                                             \
                s = _mm_add_epi32(s, _mm_madd_epi16(K8(k), _mm_set1_epi32(xlast)));         \
                k += 8;                                                                     \
            }                                                                               \
            _mm_storeu_si128((__m128i *)(void *)(acc + j), s);                              \
        }                                                                                   \
        for (; j < n_rows; j++, k += 2u * n_pairs)                                          \
            acc[j] = ROW(k, x, 2u * n_pairs);                                               \
    }

CN_DOT_AVX2(cn_dot_s16_avx2, row_s16_avx2, int16_t, k16_s16, k8_s16)
CN_DOT_AVX2(cn_dot_s8_avx2, row_s8_avx2, int8_t, k16_s8, k8_s8)

/* render.c's requant for 1 <= s <= 16, sixteen inputs a step: floor(x / 2^s) plus bit s-1
 * of x in int32 lanes (exact), packed to int16 with signed saturation (vpackssdw, lanes
 * put back in order), and summed by vpmaddwd with ones. */
__attribute__((target("avx2"))) int32_t cn_requant_s16_avx2(const int32_t *x, int16_t *xq,
                                                            uint32_t n, unsigned s)
{
    const __m128i cs = _mm_cvtsi32_si128((int)s), cb = _mm_cvtsi32_si128((int)s - 1);
    const __m256i one = _mm256_set1_epi32(1), ones16 = _mm256_set1_epi16(1);
    __m256i sum = _mm256_setzero_si256();
    uint32_t i = 0;
    for (; i + 16u <= n; i += 16u) {
        const __m256i a = _mm256_loadu_si256((const __m256i *)(const void *)(x + i));
        const __m256i b = _mm256_loadu_si256((const __m256i *)(const void *)(x + i + 8u));
        const __m256i qa = _mm256_add_epi32(_mm256_sra_epi32(a, cs),
                                            _mm256_and_si256(_mm256_srl_epi32(a, cb), one));
        const __m256i qb = _mm256_add_epi32(_mm256_sra_epi32(b, cs),
                                            _mm256_and_si256(_mm256_srl_epi32(b, cb), one));
        const __m256i q = _mm256_permute4x64_epi64(_mm256_packs_epi32(qa, qb), 0xD8);
        _mm256_storeu_si256((__m256i *)(void *)(xq + i), q);
        sum = _mm256_add_epi32(sum, _mm256_madd_epi16(q, ones16));
    }
    __m128i h = _mm_add_epi32(_mm256_castsi256_si128(sum), _mm256_extracti128_si256(sum, 1));
    h = _mm_add_epi32(h, _mm_shuffle_epi32(h, 0x4E));
    h = _mm_add_epi32(h, _mm_shuffle_epi32(h, 0xB1));
    int32_t r = _mm_cvtsi128_si32(h);
    for (; i < n; i++) { /* the last inputs as the vector steps do them */
        xq[i] = cn_requant16(x[i], s);
        r += xq[i];
    }
    return r;
}

/* sat32(a + b) in eight lanes: on overflow (a and b of one sign, the sum of the other) the
 * bound of a's sign. */
__attribute__((target("avx2"))) static inline __m256i qadd_avx2(__m256i a, __m256i b)
{
    const __m256i r = _mm256_add_epi32(a, b);
    const __m256i ov = _mm256_srai_epi32(_mm256_and_si256(_mm256_xor_si256(a, r),
                                                          _mm256_xor_si256(b, r)), 31);
    const __m256i sat = _mm256_xor_si256(_mm256_srai_epi32(a, 31), _mm256_set1_epi32(0x7FFFFFFF));
    return _mm256_blendv_epi8(r, sat, ov);
}

/* render.c's finish_fast for n < 32, eight outputs a step: the products acc am in 64-bit
 * lanes (even and odd lanes by vpmuldq), plus 2^(n-1), shifted right by n (the low word is
 * the result: bits n..n+31 of the sum, below 2^62), then the two saturating additions. */
__attribute__((target("avx2"))) void cn_finish_s32_avx2(const int32_t *acc, uint32_t live,
                                                        int32_t am, unsigned n, int32_t t,
                                                        const int32_t *bq, int32_t *y, int relu)
{
    const __m256i amv = _mm256_set1_epi32(am), half = _mm256_set1_epi64x((long long)1 << (n - 1u));
    const __m256i tv = _mm256_set1_epi32(t), zero = _mm256_setzero_si256();
    const __m128i cn = _mm_cvtsi32_si128((int)n);
    uint32_t j = 0;
    for (; j + 8u <= live; j += 8u) {
        const __m256i a = _mm256_loadu_si256((const __m256i *)(const void *)(acc + j));
        const __m256i pe = _mm256_srl_epi64(_mm256_add_epi64(_mm256_mul_epi32(a, amv), half), cn);
        const __m256i po = _mm256_srl_epi64(
            _mm256_add_epi64(_mm256_mul_epi32(_mm256_srli_epi64(a, 32), amv), half), cn);
        const __m256i ya = _mm256_blend_epi32(pe, _mm256_slli_epi64(po, 32), 0xAA);
        __m256i v = qadd_avx2(qadd_avx2(ya, tv),
                              _mm256_loadu_si256((const __m256i *)(const void *)(bq + j)));
        if (relu)
            v = _mm256_max_epi32(v, zero);
        _mm256_storeu_si256((__m256i *)(void *)(y + j), v);
    }
    for (; j < live; j++) {
        const uint64_t u = (uint64_t)((int64_t)acc[j] * am) + ((uint64_t)1 << (n - 1u));
        const uint32_t lo = ((uint32_t)u >> n) | ((uint32_t)(u >> 32) << (32u - n));
        int64_t v = (int64_t)(lo < 0x80000000u ? (int32_t)lo : -(int32_t)(~lo) - 1) + t;
        v = v > INT32_MAX ? INT32_MAX : v < INT32_MIN ? INT32_MIN : v;
        v += bq[j];
        v = v > INT32_MAX ? INT32_MAX : v < INT32_MIN ? INT32_MIN : v;
        y[j] = relu && v < 0 ? 0 : (int32_t)v;
    }
}

/* 1 when the CPU has AVX2 and the operating system saves the YMM registers. */
int cn_cpu_has_avx2(void)
{
    unsigned a, b, c, d;
    if (!__get_cpuid(1, &a, &b, &c, &d) || !(c & bit_OSXSAVE) || !(c & bit_AVX))
        return 0;
    unsigned lo, hi;
    __asm__("xgetbv" : "=a"(lo), "=d"(hi) : "c"(0));
    if ((lo & 6u) != 6u) /* the OS saves XMM and YMM state */
        return 0;
    return __get_cpuid_count(7, 0, &a, &b, &c, &d) && (b & bit_AVX2);
}
#else
typedef int cn_no_avx2; /* ISO C: a translation unit declares something */
#endif
