/*
 * WebAssembly's 128-bit SIMD (wasm32 with simd128): cn_dot_s16_simd128, exactly
 * cn_dot_s16_c's sums (cn_kernels.h): per block of four rows and input pair, one load of the
 * block's eight latents (layout CN_PAIRS), the pair splat to the four lanes, and one
 * i32x4.dot_i16x8_s, which sums each row's two products into its lane. The sums wrap modulo
 * 2^32 like the C's int32 sums, and the caller's bound makes them exact.
 */
#include "cn_kernels.h"

#if defined(CN_HAVE_SIMD128)
#include <wasm_simd128.h>

void cn_dot_s16_simd128(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                        int32_t *acc)
{
    uint32_t j = 0;
    for (; j + 4u <= n_rows; j += 4u) {
        v128_t a = wasm_i32x4_splat(0), b = wasm_i32x4_splat(0);
        uint32_t p = 0;
        for (; p + 2u <= n_pairs; p += 2u, k += 16) {
            a = wasm_i32x4_add(a, wasm_i32x4_dot_i16x8(wasm_v128_load(k),
                                                       wasm_v128_load32_splat(x + 2u * p)));
            b = wasm_i32x4_add(b, wasm_i32x4_dot_i16x8(wasm_v128_load(k + 8),
                                                       wasm_v128_load32_splat(x + 2u * p + 2u)));
        }
        if (p < n_pairs) {
            a = wasm_i32x4_add(a, wasm_i32x4_dot_i16x8(wasm_v128_load(k),
                                                       wasm_v128_load32_splat(x + 2u * p)));
            k += 8;
        }
        wasm_v128_store(acc + j, wasm_i32x4_add(a, b));
    }
    if (j < n_rows)
        cn_dot_s16_c(k, x, n_pairs, n_rows - j, acc + j);
}
#else
typedef int cn_no_simd128; /* ISO C: a translation unit declares something */
#endif
