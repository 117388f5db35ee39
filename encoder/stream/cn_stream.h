/*
 * Encoder side of the bitstream: frequency-table quantization, rANS encoding, number formats
 * and the stream writer. Host C11 (allocates, uses libm).
 */
#ifndef CNERF_ENC_STREAM_H
#define CNERF_ENC_STREAM_H

#include <stddef.h>
#include <stdint.h>

#include "cnerf/cnerf.h"
#include "cn_buf.h"

/* ---- frequency tables ---- */

/* Quantizes a PMF p[0..n) (any non-negative weights, not all zero) to frequencies
 * freq[i] >= 1 summing to 2^prec: round, clamp to >= 1, then add or remove single
 * counts where that costs the fewest bits (p_i * delta log2 f_i).
 * Returns 0, or -1 if n > 2^prec, prec > 16, or on allocation failure. */
int cn_quantize_pmf(const double *p, uint32_t n, unsigned prec, uint32_t *freq);

/* Bits of the coded table (excluding the prec/order bytes) with the best Exp-Golomb
 * order, written to *order. */
uint64_t cn_table_bits(const uint32_t *freq, uint32_t n, unsigned *order);

/* Ideal code length in bits of data with symbol counts cnt[] under table freq[]. */
double cn_table_cost_bits(const uint64_t *cnt, const uint32_t *freq, uint32_t n, unsigned prec);

/* ---- rANS ---- */

/* Encodes syms[0..count) (symbol indices < n) with the table freq[0..n) of precision
 * prec, appending the payload to `out` (decoder reads it front to back).
 * Returns 0, or -1 on invalid input or allocation failure. */
int cn_rans_encode(const uint32_t *syms, size_t count, const uint32_t *freq, uint32_t n,
                   unsigned prec, cn_buf *out);

/* Codes an occupancy grid of g^3 cells (occ[i] != 0: occupied, i = (z g + y) g + x) as a
 * BGRD payload (docs/bitstream.md, 2.3): u8 g, u8 prec, u16 occupied blocks of 8^3 cells,
 * the "occupied" frequency of each neighbour context for the blocks and then for the cells
 * (u16 each, from the grid's own counts), then binary rANS: the blocks' bits, then the
 * cells of the occupied blocks. Appends to `out`. Returns 0, or -1 on invalid input or
 * allocation failure. */
int cn_grid_encode(const uint8_t *occ, uint32_t g, unsigned prec, cn_buf *out);
/* The same grid as a GRID payload (2.0 to 2.2; for tests of those streams): u8 g, u8 prec,
 * the cells' frequencies, then every cell's bit in raster order. */
int cn_grid_encode_raster(const uint8_t *occ, uint32_t g, unsigned prec, cn_buf *out);
/* The precision the writer uses for grids. */
#define CN_GRID_PREC 12u

/* ---- number formats ---- */

/* m24e8: v ~ m * 2^e with |m| <= 2^23 - 1, e in [CNERF_EXP_MIN, CNERF_EXP_MAX], rounded
 * to nearest. Returns 0, or -1 if v is not finite or too large. */
int cn_to_m24e8(double v, int32_t *m, int8_t *e);
double cn_from_m24e8(int32_t m, int8_t e);

/* Bias block: one exponent and nbits-bit mantissas (1 <= nbits <= 24) with the largest
 * |b| using the full mantissa range. All-zero input gives *bits = 0, *e = 0.
 * Returns 0, or -1 on non-finite or too large input. */
int cn_quantize_biases(const float *b, uint32_t n, unsigned nbits, int32_t *m, uint8_t *bits,
                       int8_t *e);

/* ---- levels (docs/bitstream.md, levl) ---- */

/* What a decoder needs for the scene info describes, in the terms of the levels' caps. */
typedef struct cn_level_needs {
    size_t workspace, scratch; /* bytes */
    uint32_t grid;             /* cells per axis (0: no grid) */
    uint32_t samples;          /* coarse + fine per ray */
    uint32_t macs;             /* per evaluation of the larger network */
} cn_level_needs;
void cn_level_needs_of(const cnerf_info *I, cn_level_needs *n);
/* The caps of level L (1..CNERF_MAX_LEVELS) that the scene exceeds, as text into why ("" for
 * none, e.g. "workspace 94720 bytes > 73728"); returns how many. */
int cn_level_excess(const cnerf_info *I, unsigned L, char *why, size_t n);
/* The lowest level the scene fits, 0 for none. */
unsigned cn_level_lowest(const cnerf_info *I);

/* Re-codes the stream buf[0..len) into out (reset first), chunk by chunk: each grid becomes
 * a BGRD of the same cells, or a GRID with `cells` (for decoders of 2.2 and before); the
 * level declared becomes `level` (1..CNERF_MAX_LEVELS; 0 none, -1 the stream's own), in a
 * levl chunk right after the first HEAD; every other chunk is copied as it is, so every
 * scene renders the same pixels. The minor version becomes the lowest whose chunks and
 * values the result holds. The result is parsed back: -1 with a message when the input is
 * not a valid stream or a scene does not fit the level (what exceeds it), else 0. */
int cn_recode(const uint8_t *buf, size_t len, int level, int cells, cn_buf *out, char *err,
              size_t errlen);

/* ---- the stream writer ---- */

enum cn_table_source { CN_TABLE_NONE = 0, CN_TABLE_COUNTS = 1, CN_TABLE_PRIOR = 2 };

typedef struct cn_layer_src {
    const int32_t *k; /* n_out * n_in latents, row-major [out][in] */
    int8_t f_in;      /* input scale (CNERF_F_MIN..CNERF_F_MAX; cn_choose_scales) */
    int32_t a_m, b_m;
    int8_t a_e, b_e;
    const int32_t *bias_m; /* n_out mantissas, NULL for all-zero */
    uint8_t bias_bits;
    int8_t bias_e;
    /* Optional model PMF (the prior's discretized density) over k = pmf_kmin + i,
     * i < pmf_n. When given, the writer also tries a table built from it. */
    const double *pmf;
    int32_t pmf_kmin;
    uint32_t pmf_n;
} cn_layer_src;

typedef struct cn_stream_src {
    /* Render parameters and topology: coord, l_pos, l_dir, pe_flags, near_q16, far_q16,
     * aabb_q16, background, n_coarse, n_fine, n_nets, net[].depth/width/skip/view_width;
     * and scene 0's level: the stream's (a levl chunk; 0 none). Everything else is
     * derived. */
    cnerf_info hdr;
    cn_layer_src layer[CNERF_MAX_LAYERS];
    const char *meta; /* optional provenance text for the 'meta' chunk */
    /* Optional occupancy grid: grid_g^3 flags (non-zero: occupied), x fastest; grid_g = 0
     * writes none. */
    const uint8_t *grid;
    uint32_t grid_g;
} cn_stream_src;

/* A layer's shift shared by every scene of a set (SHFT chunk). */
typedef struct cn_shift_src {
    const int32_t *s; /* n_out * n_in shifts, row-major [out][in]; NULL: all zero */
    int32_t g_m;      /* g = g_m 2^g_e, m24e8 */
    int8_t g_e;
    const double *pmf; /* optional prior PMF over s = pmf_kmin + i, as cn_layer_src */
    int32_t pmf_kmin;
    uint32_t pmf_n;
} cn_shift_src;

typedef struct cn_write_report {
    uint8_t table_source[CNERF_MAX_LAYERS]; /* enum cn_table_source per layer */
    double ideal_bits[CNERF_MAX_LAYERS];    /* -sum log2 of the chosen table's probabilities */
} cn_write_report;

/* Appends a HEAD payload (render parameters and topology of hdr) to h. */
void cn_put_head(cn_buf *h, const cnerf_info *hdr);

/* 1 when a layer of the (expanded) topology has fewer units than its network's width:
 * the stream then carries a UNIT chunk. */
int cn_topology_pruned(const cnerf_info *I);
/* Writes the whole stream into `out` (which is reset first), then reads it back with
 * the decoder's parser. On failure returns -1 and puts a message in err. */
int cn_write_stream(const cn_stream_src *src, cn_buf *out, cn_write_report *rep, char *err,
                    size_t errlen);
/* The same for a set of n_scenes scenes of one topology (1..CNERF_MAX_SCENES) with one
 * cn_shift_src per layer (a SCNS chunk and SHFT chunks); shift NULL (one scene only) is
 * cn_write_stream. The meta text is scenes[0]'s. rep: NULL or one report per scene; shift_rep: NULL or the shifts' report. */
int cn_write_set(const cn_stream_src *scenes, unsigned n_scenes, const cn_shift_src *shift,
                 cn_buf *out, cn_write_report *rep, cn_write_report *shift_rep, char *err,
                 size_t errlen);

#endif /* CNERF_ENC_STREAM_H */
