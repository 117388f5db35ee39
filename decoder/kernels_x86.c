/*
 * x86-64 kernels, chosen at run time: AVX2 (vpmaddwd: sixteen 16-bit products summed in
 * pairs into eight int32) when the CPU has it and the operating system saves its
 * registers. Computes exactly cn_dot_c's sums (cn_kernels.h).
 */
#include "cn_kernels.h"

#if !defined(CNERF_PORTABLE) && defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <cpuid.h>
#include <immintrin.h>

/* Each 256-bit load holds two input pairs of the block's four rows; multiplied with the
 * first pair repeated in the low half and the second in the high half, vpmaddwd gives the
 * four rows' sums over each pair. */
__attribute__((target("avx2"))) static void dot_avx2(const int16_t *k, const int16_t *x,
                                                     uint32_t n_pairs, uint32_t n_rows,
                                                     int32_t *acc)
{
    const __m256i spread = _mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1);
    uint32_t j = 0;
    for (; j + 4u <= n_rows; j += 4u) {
        __m256i a = _mm256_setzero_si256();
        uint32_t p = 0;
        for (; p + 2u <= n_pairs; p += 2u, k += 16) {
            const __m256i xx = _mm256_permutevar8x32_epi32(
                _mm256_castsi128_si256(_mm_loadl_epi64((const __m128i *)(const void *)(x + 2u * p))),
                spread);
            const __m256i w = _mm256_loadu_si256((const __m256i *)(const void *)k);
            a = _mm256_add_epi32(a, _mm256_madd_epi16(w, xx));
        }
        __m128i s = _mm_add_epi32(_mm256_castsi256_si128(a), _mm256_extracti128_si256(a, 1));
        if (p < n_pairs) {
            int32_t xv;
            __builtin_memcpy(&xv, x + 2u * p, 4);
            const __m128i w = _mm_loadu_si128((const __m128i *)(const void *)k);
            s = _mm_add_epi32(s, _mm_madd_epi16(w, _mm_set1_epi32(xv)));
            k += 8;
        }
        _mm_storeu_si128((__m128i *)(void *)(acc + j), s);
    }
    if (j < n_rows)
        cn_dot_c(k, x, n_pairs, n_rows - j, acc + j);
}

static int have_avx2(void)
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

uint32_t cn_dot_variants_x86(cn_dot_variant *out)
{
    if (!have_avx2())
        return 0;
    out[0].name = "avx2";
    out[0].fn = dot_avx2;
    return 1;
}
#else
uint32_t cn_dot_variants_x86(cn_dot_variant *out)
{
    (void)out;
    return 0;
}
#endif
