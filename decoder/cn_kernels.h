/*
 * The networks' dot-product kernels (docs/decoder.md, Kernels). A layer's live latent rows
 * are stored packed (cnerf_decoder.latent): blocks of four rows, each block input pair by
 * input pair, k[r][2p] and k[r][2p+1] for each row r; the remaining one to three rows
 * follow row after row. The portable C kernel is the definition; every other kernel
 * computes the same sums and is checked against it (tests/xarch/check_kernels.c).
 * Freestanding: <stdint.h> only.
 */
#ifndef CNERF_DECODER_KERNELS_H
#define CNERF_DECODER_KERNELS_H

#include <stdint.h>

/* Which Arm kernels this build has (kernels_arm.c), chosen at compile time: the sums by
 * Helium, else the DSP extension, else Advanced SIMD; the inputs' quantization and the
 * outputs' rescale by the DSP extension wherever it exists (Cortex-M4, M7, M33, M55). */
#if !defined(CNERF_PORTABLE) && defined(__ARM_FEATURE_MVE) && (__ARM_FEATURE_MVE & 1)
#define CN_HAVE_MVE 1
#endif
#if !defined(CNERF_PORTABLE) && defined(__ARM_FEATURE_DSP) && !defined(__aarch64__)
#define CN_HAVE_DSP 1
#endif
#if !defined(CNERF_PORTABLE) && defined(__aarch64__) && defined(__ARM_NEON)
#define CN_HAVE_NEON 1
#endif

/* acc[j] = sum_i k[j][i] x[i] over 2 n_pairs inputs for the n_rows packed rows, in int32:
 * the caller has proved that no partial sum leaves the int32 range (cnerf_open), so every
 * order of summation gives the same value. */
typedef void (*cn_dot_fn)(const int16_t *k, const int16_t *x, uint32_t n_pairs,
                          uint32_t n_rows, int32_t *acc);

void cn_dot_c(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
              int32_t *acc);

/* The same sums in int64, for layers whose int32 bound does not hold (portable C only). */
void cn_dot64_c(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                int64_t *acc);


/* A layer's inputs at its scale, for 1 <= s <= 16 (render.c's requant): xq[i] =
 * sat16(floor(x[i] / 2^s + 1/2)) for i < n; returns their sum. */
typedef int32_t (*cn_requant_fn)(const int32_t *x, int16_t *xq, uint32_t n, unsigned s);

/* The outputs of a layer's live rows in stored row order, for 1 <= n < 32 where cnerf_open
 * proved the fast rescale (render.c's finish_fast): y[j] = sat32(sat32(((acc[j] am +
 * 2^(n-1)) >> n) + t) + bq[j]), then max(0, .) when relu. */
typedef void (*cn_finish_fn)(const int32_t *acc, uint32_t live, int32_t am, unsigned n,
                             int32_t t, const int32_t *bq, int32_t *y, int relu);

typedef struct cn_dot_variant {
    const char *name;
    cn_dot_fn fn;
    cn_requant_fn requant; /* NULL: the portable C */
    cn_finish_fn finish;   /* NULL: the portable C */
} cn_dot_variant;

/* The fastest kernels this build and CPU have (x86-64: AVX2 when the CPU and the OS
 * support it; Arm: chosen at compile time; CNERF_PORTABLE builds: cn_dot_c). */
cn_dot_variant cn_dot_select(void);

#define CN_DOT_MAX_VARIANTS 4u

/* Writes every kernel this build holds that can run on this CPU into out, the portable
 * one first and the fastest last; returns how many. This is the one place of the CPU
 * dispatch. */
uint32_t cn_dot_variants(cn_dot_variant out[CN_DOT_MAX_VARIANTS]);

/* The per-architecture parts (kernels_x86.c, kernels_arm.c): each appends the kernels of
 * its architecture that run here and returns how many (at most 2). */
uint32_t cn_dot_variants_x86(cn_dot_variant *out);
uint32_t cn_dot_variants_arm(cn_dot_variant *out);

#if defined(CN_HAVE_DSP)
/* The layer inputs' quantization of render.c (requant) for 1 <= s <= 16 on the DSP
 * extension: xq[i] = sat16(sat32(x[i] + 2^(s-1)) >> s) for i < n; returns their sum. */
int32_t cn_requant_arm(const int32_t *x, int16_t *xq, uint32_t n, unsigned s);
/* render.c's finish_fast for 1 <= n < 32 on the DSP extension (the same values). */
void cn_finish_arm(const int32_t *acc, uint32_t live, int32_t am, unsigned n, int32_t t,
                   const int32_t *bq, int32_t *y, int relu);
#endif

/* Builds whose kernel is fixed at compile time call it directly (a known call graph for
 * the stack bound of firmware builds); the others go through cnerf_decoder.dot. */
#if defined(CN_HAVE_MVE) || defined(CN_HAVE_DSP) || defined(CN_HAVE_NEON)
void cn_dot_arm(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                int32_t *acc);
#define CN_DOT_DIRECT cn_dot_arm
#elif defined(CNERF_PORTABLE) || !defined(__x86_64__)
#define CN_DOT_DIRECT cn_dot_c
#endif

#endif /* CNERF_DECODER_KERNELS_H */
