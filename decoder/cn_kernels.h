/*
 * The networks' kernels (docs/decoder.md, Kernels), named by operation and operand types
 * as CMSIS-NN names its functions, with the instruction set last: cn_dot_s16_dsp is the dot
 * product of int16 operands (int32 sums) on the Arm DSP extension. The portable C in
 * decoder/ (kernels.c) is the definition; the others, one file per instruction set
 * (kernels_dsp.c, kernels_mve.c, kernels_neon.c, kernels_simd128.c, kernels_avx2.c), compute
 * the same values and are checked against it (tests/xarch/check_kernels.c). The choice
 * among them is made in one place, kernels.c.
 *
 * A layer's live latent rows are stored packed (cnerf_decoder.latent), as int8 when the
 * layer's latent range fits it (cn_latents_s8) and as int16 otherwise, in one of three
 * layouts (cn_packed_index), the one the chosen kernels read: blocks of four rows, each
 * block either input pair by input pair, k[r][2p] and k[r][2p+1] for each row r (layout
 * CN_PAIRS), or run by run of eight inputs, the run's eight latents of each row r in turn
 * (CN_RUNS8: Helium's dual multiply-accumulates across a vector), or, for int8 latents on
 * the DSP extension, input pair by input pair with the bytes of two rows crossed
 * (CN_PAIRS_X: SXTB16 widens a word into one row's pair); the remaining one to three rows
 * follow row after row in all three. A layer whose latents are mostly zero may instead be
 * stored as lists of its non-zero latents (cn_spdot_fn), when that is cheaper for the
 * chosen kernels (cnerf_open, decoder/open.c).
 * Freestanding: <stdint.h> only.
 */
#ifndef CNERF_DECODER_KERNELS_H
#define CNERF_DECODER_KERNELS_H

#include <stdint.h>

/* Which kernels this build has. Arm, chosen at compile time: the sums by
 * Helium, else the DSP extension, else Advanced SIMD; the inputs' quantization and the
 * outputs' rescale by the DSP extension wherever it exists (Cortex-M4, M7, M33, M55).
 * x86-64: AVX2, each function compiled for its target and chosen at run
 * time. CNERF_PORTABLE builds have the portable C only. */
#if !defined(CNERF_PORTABLE) && defined(__ARM_FEATURE_MVE) && (__ARM_FEATURE_MVE & 1)
#define CN_HAVE_MVE 1
#endif
#if !defined(CNERF_PORTABLE) && defined(__ARM_FEATURE_DSP) && !defined(__aarch64__)
#define CN_HAVE_DSP 1
#endif
#if !defined(CNERF_PORTABLE) && defined(__aarch64__) && defined(__ARM_NEON)
#define CN_HAVE_NEON 1
#endif
#if !defined(CNERF_PORTABLE) && defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define CN_HAVE_AVX2 1
#endif
#if !defined(CNERF_PORTABLE) && defined(__wasm_simd128__)
#define CN_HAVE_SIMD128 1
#endif

/* ---- the packed layouts ---- */

#define CN_PAIRS 0u /* a block's latents input pair by input pair */
#define CN_RUNS8 1u /* a block's latents run by run of eight inputs */
#define CN_PAIRS_X 2u /* int8 only: pair by pair, rows 0 and 1 (2 and 3) crossed in a word */
/* On an Arm M-profile core only builds with Helium's kernels pack in CN_RUNS8 (the others
 * leave its code out); other hosts have every layout, for cnerf_pack's images of any core. */
#if defined(CN_HAVE_MVE) || !(defined(__ARM_ARCH_PROFILE) && __ARM_ARCH_PROFILE == 'M')
#define CN_RUNS8_BUILT 1
#else
#define CN_RUNS8_BUILT 0
#endif
/* Likewise only M-profile builds with the DSP extension's int8 sums pack in CN_PAIRS_X. */
#if (defined(CN_HAVE_DSP) && !defined(CN_HAVE_MVE)) ||                                      \
    !(defined(__ARM_ARCH_PROFILE) && __ARM_ARCH_PROFILE == 'M')
#define CN_PAIRS_X_BUILT 1
#else
#define CN_PAIRS_X_BUILT 0
#endif

/* 1 when a layer's latents kmin..kmax are stored as int8 (else int16): a property of the
 * stream alone, so the workspace's size is the same whichever kernels a CPU chooses. */
static inline int cn_latents_s8(int32_t kmin, int32_t kmax)
{
    return kmin >= -128 && kmax <= 127;
}

/* The index of latent k[j][i] of stored row j among `live` packed rows of 2 pairs inputs,
 * in layout `layout`. A block of four rows holds 8 pairs latents either way; in CN_RUNS8 a
 * last run of m < 8 inputs holds each row's m latents in turn; in CN_PAIRS_X a pair's eight
 * bytes are k[0][2p], k[1][2p], k[0][2p+1], k[1][2p+1], then rows 2 and 3 the same way.
 * The last one to three rows (a block that is not full) are row after row in all
 * layouts. */
static inline uint32_t cn_packed_index(uint32_t j, uint32_t i, uint32_t live, uint32_t pairs,
                                       uint32_t layout)
{
    const uint32_t b = j >> 2, q = j & 3u, base = b * 8u * pairs;
    if ((b + 1u) * 4u > live) /* the last one to three rows: row after row */
        return base + q * 2u * pairs + i;
    if (CN_RUNS8_BUILT && layout == CN_RUNS8) {
        const uint32_t run = i >> 3, left = 2u * pairs - 8u * run;
        return base + 32u * run + q * (left < 8u ? left : 8u) + (i & 7u);
    }
    if (CN_PAIRS_X_BUILT && layout == CN_PAIRS_X)
        return base + (i >> 1) * 8u + 4u * (q >> 1) + 2u * (i & 1u) + (q & 1u);
    return base + (i >> 1) * 8u + 2u * q + (i & 1u);
}

/* ---- the operations ---- */

/* dot_s16: acc[j] = sum_i k[j][i] x[i] over 2 n_pairs int16 inputs for the n_rows packed
 * int16 rows (in the layout of the kernel's set, cn_dot_variant.layout), in int32: the
 * caller has proved that no partial sum leaves the int32 range (cnerf_open), so every
 * order of summation gives the same value. */
typedef void (*cn_dot_fn)(const int16_t *k, const int16_t *x, uint32_t n_pairs,
                          uint32_t n_rows, int32_t *acc);

/* dot_s8: the same sums over int8 latents (a layer whose range fits, cn_latents_s8), in the
 * int8 layout of the kernel's set (cn_dot_variant.layout8). */
typedef void (*cn_dot8_fn)(const int8_t *k, const int16_t *x, uint32_t n_pairs,
                           uint32_t n_rows, int32_t *acc);

/* spdot_s16: the same sums over a sparse layer: for each of the n_rows live rows, one word
 * holding its count n of non-zero latents, then n words, each 2 i << 16 | (uint16_t)k for
 * the latent k of input i (i < 2^15: the input's byte offset in x sits in the high half).
 * The caller proved the int32 bound as for dot_s16 (the same latents, zeros left out).
 * Returns the non-zero latents multiplied (the rows' counts). */
/* The latent of a list entry: its low half as int16 (without an implementation-defined
 * conversion; compilers make it one sign extension). */
static inline int32_t cn_entry_k(uint32_t w)
{
    return (int32_t)(w & 0xffffu) - (int32_t)(w & 0x8000u) * 2;
}

typedef uint32_t (*cn_spdot_fn)(const uint32_t *e, const int16_t *x, uint32_t n_rows,
                                int32_t *acc);

/* requant_s16: a layer's inputs at its scale, for 1 <= s <= 16 (render.c's requant):
 * xq[i] = sat16(floor(x[i] / 2^s + 1/2)) for i < n; returns their sum. */
typedef int32_t (*cn_requant_fn)(const int32_t *x, int16_t *xq, uint32_t n, unsigned s);

/* finish_s32: the outputs of a layer's live rows in stored row order, for 1 <= n < 32 where
 * cnerf_open proved the fast rescale (render.c's finish_fast): y[j] = sat32(sat32(((acc[j]
 * am + 2^(n-1)) >> n) + t) + bq[j]), then max(0, .) when relu. */
typedef void (*cn_finish_fn)(const int32_t *acc, uint32_t live, int32_t am, unsigned n,
                             int32_t t, const int32_t *bq, int32_t *y, int relu);

/* ---- the portable C (kernels.c; requant and finish: render.c) ---- */

void cn_dot_s16_c(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                  int32_t *acc);

uint32_t cn_spdot_s16_c(const uint32_t *e, const int16_t *x, uint32_t n_rows, int32_t *acc);

/* The same sums in int64, for layers whose int32 bound does not hold (portable C only;
 * layout CN_PAIRS whatever the chosen set). */
void cn_dot_s16_s64_c(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                      int64_t *acc);

/* The sums over int8 latents in layout CN_PAIRS, in int32 and in int64. */
void cn_dot_s8_c(const int8_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                 int32_t *acc);
void cn_dot_s8_s64_c(const int8_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                     int64_t *acc);

/* ---- Arm ---- */

#if defined(CN_HAVE_DSP) && !defined(CN_HAVE_MVE)
/* kernels_dsp.c: SMLAD, 16 multiply-accumulates in 15 instructions */
void cn_dot_s16_dsp(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                    int32_t *acc);
/* kernels_dsp.c: int8 latents in layout CN_PAIRS_X, SXTB16 and SMLAD */
void cn_dot_s8_dsp(const int8_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                   int32_t *acc);
#endif
#if defined(CN_HAVE_DSP)
/* kernels_dsp.c: SMLABB, two non-zero latents in seven instructions */
uint32_t cn_spdot_s16_dsp(const uint32_t *e, const int16_t *x, uint32_t n_rows, int32_t *acc);
/* kernels_dsp.c: QADD, SSAT and PKHBT, two inputs a step */
int32_t cn_requant_s16_dsp(const int32_t *x, int16_t *xq, uint32_t n, unsigned s);
/* kernels_dsp.c: SMLAL and two QADDs, two outputs a step */
void cn_finish_s32_dsp(const int32_t *acc, uint32_t live, int32_t am, unsigned n, int32_t t,
                       const int32_t *bq, int32_t *y, int relu);
#endif
#if defined(CN_HAVE_MVE)
/* kernels_mve.c: Helium. The sums in layout CN_RUNS8, VMLADAVA over a run of eight
 * inputs: one load of the run's inputs and, per row of the block, one load and one
 * instruction for its eight multiply-accumulates */
void cn_dot_s16_mve(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                    int32_t *acc);
/* kernels_mve.c: the same over int8 latents, each run's eight widened by its load
 * (VLDRB.S16) */
void cn_dot_s8_mve(const int8_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                   int32_t *acc);
/* kernels_mve.c: eight inputs a step (VLD2, VRSHL, VQMOVNB/VQMOVNT, VADDVA) */
int32_t cn_requant_s16_mve(const int32_t *x, int16_t *xq, uint32_t n, unsigned s);
/* kernels_mve.c: four outputs a step (VMUL, VMULH, shifts, VQADD) */
void cn_finish_s32_mve(const int32_t *acc, uint32_t live, int32_t am, unsigned n, int32_t t,
                       const int32_t *bq, int32_t *y, int relu);
#endif
#if defined(CN_HAVE_NEON)
/* kernels_neon.c: vmlal_s16/vmlal_high_s16 over a block's input pair */
void cn_dot_s16_neon(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                     int32_t *acc);
/* kernels_neon.c: int8 latents, two blocks' pairs widened by vmovl_s8 */
void cn_dot_s8_neon(const int8_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                    int32_t *acc);
#endif

/* ---- WebAssembly ---- */

#if defined(CN_HAVE_SIMD128)
/* kernels_simd128.c: i32x4.dot_i16x8_s over a block's input pair */
void cn_dot_s16_simd128(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                        int32_t *acc);
/* kernels_simd128.c: int8 latents widened by their load (i16x8.load8x8_s) */
void cn_dot_s8_simd128(const int8_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                       int32_t *acc);
/* kernels_simd128.c: eight inputs a step */
int32_t cn_requant_s16_simd128(const int32_t *x, int16_t *xq, uint32_t n, unsigned s);
/* kernels_simd128.c: four outputs a step (i64x2.extmul) */
void cn_finish_s32_simd128(const int32_t *acc, uint32_t live, int32_t am, unsigned n, int32_t t,
                           const int32_t *bq, int32_t *y, int relu);
#endif

/* ---- x86-64 ---- */

#if defined(CN_HAVE_AVX2)
/* kernels_avx2.c: 1 when the CPU has AVX2 and the operating system saves its registers */
int cn_cpu_has_avx2(void);
/* kernels_avx2.c: vpmaddwd over two input pairs of a block */
void cn_dot_s16_avx2(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                     int32_t *acc);
/* kernels_avx2.c: int8 latents widened by vpmovsxbw, then as cn_dot_s16_avx2 */
void cn_dot_s8_avx2(const int8_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                    int32_t *acc);
/* kernels_avx2.c: sixteen inputs a step */
int32_t cn_requant_s16_avx2(const int32_t *x, int16_t *xq, uint32_t n, unsigned s);
/* kernels_avx2.c: eight outputs a step */
void cn_finish_s32_avx2(const int32_t *acc, uint32_t live, int32_t am, unsigned n, int32_t t,
                        const int32_t *bq, int32_t *y, int relu);
#endif

/* ---- the choice (kernels.c) ---- */

/* A set of kernels: the sums, and the inputs' quantization and the outputs' rescale that
 * go with them (NULL: render.c's portable C). */
typedef struct cn_dot_variant {
    const char *name; /* the instruction set: "c", "dsp", "mve", "neon", "simd128", "avx2" */
    cn_dot_fn fn;
    cn_dot8_fn fn8; /* the sums over int8 latents */
    cn_requant_fn requant;
    cn_finish_fn finish;
    cn_spdot_fn spdot;
    /* What the sums cost, in sixteenths of an instruction (or of a cycle where instructions
     * are not counted): fn per multiply-accumulate over the padded live rows, spdot per
     * non-zero latent and per live row. cnerf_open stores a layer sparse when spdot costs
     * less (the workspace is the same either way: the lists fit in the packed layer's
     * place, or the layer stays packed). docs/decoder.md, "Zero latents", says how they
     * were measured. */
    uint16_t mac_cost, nz_cost, row_cost;
    uint16_t mac8_cost; /* fn8 per multiply-accumulate (int8 latents) */
    uint8_t layout;  /* the packed layout fn reads: CN_PAIRS or CN_RUNS8 */
    uint8_t layout8; /* the one fn8 reads: CN_PAIRS, CN_RUNS8 or CN_PAIRS_X */
} cn_dot_variant;

#define CN_DOT_MAX_VARIANTS 4u

/* Writes every kernel set this build holds that can run on this CPU into out, the portable
 * one first and the fastest last; returns how many. This is the one place of the CPU
 * dispatch. */
uint32_t cn_dot_variants(cn_dot_variant out[CN_DOT_MAX_VARIANTS]);

/* The portable C kernels with the costs of the set named `set` ("c", "dsp", "mve", "neon",
 * "avx2"), whichever this build holds: a device's choice of forms, computed anywhere.
 * Returns 1, or 0 for an unknown name. */
int cn_dot_variant_as(const char *set, cn_dot_variant *out);

/* The same costs with the layouts of that set's own kernels ("dsp": int8 latents in
 * CN_PAIRS_X, "mve": CN_RUNS8): a workspace packed for that device (cnerf_pack), which only
 * its own kernels sum. Returns 1, or 0 for an unknown name. */
int cn_dot_variant_target(const char *set, cn_dot_variant *out);

/* The fastest kernels this build and CPU have (x86-64: AVX2 when the CPU and the OS
 * support it; Arm: chosen at compile time; CNERF_PORTABLE builds: the portable C). */
cn_dot_variant cn_dot_select(void);

/* Builds whose kernel is fixed at compile time call it directly (a known call graph for
 * the stack bound of firmware builds); the others go through cnerf_decoder.dot. */
#if defined(CN_HAVE_DSP)
#define CN_SPDOT_DIRECT cn_spdot_s16_dsp
#elif !defined(CN_HAVE_AVX2)
#define CN_SPDOT_DIRECT cn_spdot_s16_c
#endif
#if defined(CN_HAVE_MVE)
#define CN_DOT_DIRECT cn_dot_s16_mve
#define CN_DOT8_DIRECT cn_dot_s8_mve
#elif defined(CN_HAVE_DSP)
#define CN_DOT_DIRECT cn_dot_s16_dsp
#define CN_DOT8_DIRECT cn_dot_s8_dsp
#elif defined(CN_HAVE_NEON)
#define CN_DOT_DIRECT cn_dot_s16_neon
#define CN_DOT8_DIRECT cn_dot_s8_neon
#elif defined(CN_HAVE_SIMD128)
#define CN_DOT_DIRECT cn_dot_s16_simd128
#define CN_DOT8_DIRECT cn_dot_s8_simd128
#elif !defined(CN_HAVE_AVX2)
#define CN_DOT_DIRECT cn_dot_s16_c
#define CN_DOT8_DIRECT cn_dot_s8_c
#endif

#endif /* CNERF_DECODER_KERNELS_H */
