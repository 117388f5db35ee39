/*
 * Decoder internals shared by its translation units (and by unit tests).
 * Freestanding: <stdint.h>, <stddef.h> only.
 */
#ifndef CNERF_DECODER_INTERNAL_H
#define CNERF_DECODER_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "cnerf/cnerf.h"

#include "../common/cn_reader.h"
#include "../common/cn_grid_model.h"
#include "cn_kernels.h"

/* ---- the decoder's state: cnerf_decoder's opaque part ---- */

#define CN_FORM_PACKED 0u
#define CN_FORM_WIDE 1u
#define CN_FORM_SPARSE 2u

typedef struct cn_state {
    /* Latents as int8 where the layer's range fits (cn_latents_s8), else widened to int16,
     * packed for the dot-product kernels (docs/decoder.md): the n_live[l] rows with a
     * non-zero latent, in increasing output order, in blocks of four rows, each block in
     * layout `layout` (int16, int32 sums), `layout8` (int8, int32 sums) or CN_PAIRS (int64
     * sums: cn_packed_index in cn_kernels.h); the remaining one to three rows row after row;
     * inputs padded to n_pairs[l] pairs with zero; the columns fed by a hidden layer in
     * that layer's stored row order; or, for a layer whose form is CN_FORM_SPARSE, the
     * lists of cn_spdot_fn in the same place. cnerf_latent reads one latent by output and
     * input index. */
    const void *latent[CNERF_MAX_LAYERS];
    const int32_t *bias[CNERF_MAX_LAYERS];     /* n_out bias mantissas, by output */
    const int32_t *bias_q16[CNERF_MAX_LAYERS]; /* sat32(round(bias 2^16)), by stored row */
    /* Per layer the output index of each stored row: the n_live[l] rows with a non-zero
     * latent first, then the all-zero rows, whose sum k x is 0 and is not computed. */
    const uint16_t *rows[CNERF_MAX_LAYERS];
    /* Several-scene streams: the layer's shared shifts s, packed like its latents (same
     * stored rows), or NULL for a layer without a shift. */
    const int16_t *shift[CNERF_MAX_LAYERS];
    uint16_t n_live[CNERF_MAX_LAYERS];
    uint16_t n_pairs[CNERF_MAX_LAYERS]; /* (n_in + 1) / 2 */
    /* How cnerf_open stored and proved each layer's sums (form): CN_FORM_WIDE when a sum of
     * k x_q may leave the int32 range (then it is formed in int64); CN_FORM_SPARSE when the
     * live rows are stored as lists of their non-zero latents (cn_spdot_fn's layout, in the
     * packed layer's place) because the chosen kernels sum those faster; else
     * CN_FORM_PACKED. a_shift in 1..62 when the rescale of an int32 sum is one product and
     * one shift with no saturation, else 0. Either way the values are the same; only the
     * speed differs. shift_wide as CN_FORM_WIDE, for the sums s x_q. */
    uint8_t form[CNERF_MAX_LAYERS];
    uint8_t a_shift[CNERF_MAX_LAYERS];
    uint8_t b_shift[CNERF_MAX_LAYERS]; /* the same for the term b sum x_q (|sum| < 2^26) */
    uint8_t shift_wide[CNERF_MAX_LAYERS];
    /* 1: every layer's latents stored as int16, int8 range or not (cnerf_open given
     * cnerf_workspace_size_fast bytes, on kernels whose int8 sums cost more); else int8
     * where the range fits (cn_latents_s8). Packed images: 0. */
    uint8_t k16;
    uint8_t layout;  /* the chosen kernels' packed layout (cn_dot_variant.layout) */
    uint8_t layout8; /* and the one of their int8 sums (cn_dot_variant.layout8) */
    /* The kernels cnerf_open chose for this CPU (docs/decoder.md, Kernels): the sums, and,
     * where the CPU has its own (NULL: the portable C), the inputs' quantization and the
     * outputs' rescale. */
    void (*dot)(const int16_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                int32_t *acc);
    void (*dot8)(const int8_t *k, const int16_t *x, uint32_t n_pairs, uint32_t n_rows,
                 int32_t *acc);
    uint32_t (*spdot)(const uint32_t *e, const int16_t *x, uint32_t n_rows, int32_t *acc);
    int32_t (*requant)(const int32_t *x, int16_t *xq, uint32_t n, unsigned s);
    void (*finish)(const int32_t *acc, uint32_t live, int32_t am, unsigned n, int32_t t,
                   const int32_t *bq, int32_t *y, int relu);
    /* The occupancy grid stored by blocks (cn_grid_model.h; NULL grid_slot: no grid): a
     * record index per block of 8^3 cells, the records (cells and summary levels 1 and 2),
     * and the summary's levels 3 and up, made at open (open.c, build_summary): level k of
     * ceil(g / 2^k)^3 cells, each set when any grid cell it covers is occupied, stored one
     * after another bit by bit down to one cell. The renderer rules out a stretch of a ray
     * with a few of its bits. */
    const uint16_t *grid_slot;
    const uint8_t *grid_rec;
    const uint8_t *grid_summary;
    uint32_t grid_occupied; /* occupied cells */
    uint32_t grid_recs;     /* records */
} cn_state;

/* The state in dec's opaque part (whose union aligns it for pointers and 64-bit integers;
 * open.c checks at compile time that it fits). */
static inline cn_state *cn_state_of(cnerf_decoder *dec)
{
    return (cn_state *)(void *)dec->opaque.bytes;
}
static inline const cn_state *cn_cstate_of(const cnerf_decoder *dec)
{
    return (const cn_state *)(const void *)dec->opaque.bytes;
}

struct cn_dot_variant;
/* cnerf_open_scene with the kernels v (cn_kernels.h) instead of this CPU's fastest: their
 * costs decide which layers are stored sparse, and, when `fast` is 1, whether latents of
 * int8 range are kept as int16 in a workspace of cnerf_workspace_size_fast bytes. Tests
 * open a stream with each form. */
cnerf_status cn_open_with(cnerf_decoder *dec, const uint8_t *buf, size_t len, uint32_t scene,
                          void *ws, size_t ws_size, const struct cn_dot_variant *v, int fast);

/* 1 when layer L's latents are stored as int8 in the decoder of state ds. */
static inline int cn_layer_s8(const cn_state *ds, const cnerf_layer_info *L)
{
    return !ds->k16 && cn_latents_s8(L->kmin, L->kmax);
}

/* cnerf_open_packed for the kernels v: tests open images packed for any device with them
 * (cn_dot_variant_target), and read them back through cnerf_latent. */
cnerf_status cn_open_packed_with(cnerf_decoder *dec, const uint8_t *image, size_t len,
                                 const struct cn_dot_variant *v);

/* ---- frequency tables and rANS ---- */

/* Parses a coded frequency table of `n` >= 2 symbols with precision `prec` and
 * Exp-Golomb order `k` from b. Writes the cumulative table cum[0..n] (cum[0] = 0,
 * cum[n] = 2^prec) when `cum` is not NULL. Returns CNERF_OK or CNERF_E_TABLE (also for
 * a table that runs past its chunk). */
cnerf_status cn_table_read(cn_bits *b, uint32_t n, unsigned prec, unsigned k, uint32_t *cum);

/* Decodes `count` symbols from the rANS payload[0..len) with the cumulative table
 * cum[0..n] of precision `prec`. Symbol s is stored as (s + offset) into out, an array
 * of elements of `elem_bytes` (1: int8_t, 2: int16_t, 4: int32_t). The payload must
 * be consumed exactly and end in the encoder's initial state, else CNERF_E_PAYLOAD. */
cnerf_status cn_rans_decode(const uint8_t *payload, size_t len, const uint32_t *cum, uint32_t n,
                            unsigned prec, int32_t offset, void *out, unsigned elem_bytes,
                            uint32_t count);

/* An occupancy grid's coding: GRID (fb1 NULL) or BGRD (docs/bitstream.md). */
typedef struct cn_grid_code {
    uint32_t g;
    unsigned prec;
    const uint16_t *f1;  /* the cells' "occupied" frequencies per context */
    const uint16_t *fb1; /* BGRD: the blocks'; NULL for GRID */
    uint32_t recs;       /* records: BGRD's occupied blocks, GRID's every block */
} cn_grid_code;

/* Decodes a GRID or BGRD payload[0..len) into the grid stored by blocks (cn_grid_model.h):
 * slot[ceil(g / 8)^3] and gc->recs records' cells (their summary bits are left 0). GRID
 * gives block b record b; BGRD gives the occupied blocks records 0, 1, ... in block order
 * and the others CN_GRID_NO_BLOCK. Counts the occupied cells into *occupied.
 * CNERF_E_PAYLOAD unless the payload is consumed exactly and ends in the encoder's initial
 * state, and, for BGRD, gc->recs blocks are occupied and each has an occupied cell. */
cnerf_status cn_grid_decode(const uint8_t *payload, size_t len, const cn_grid_code *gc,
                            uint16_t *slot, uint8_t *rec, uint32_t *occupied);

/* The coding of info's grid, gc's frequencies pointing into info. */
static inline cn_grid_code cn_grid_code_of(const cnerf_info *info)
{
    const uint32_t nb = ((uint32_t)info->grid_g + CN_GRID_B - 1u) / CN_GRID_B;
    cn_grid_code gc = {info->grid_g, info->grid_prec, info->grid_f1,
                       info->grid_by_blocks ? info->grid_fb1 : (const uint16_t *)0,
                       info->grid_by_blocks ? info->grid_blocks : nb * nb * nb};
    return gc;
}

/* ---- HEAD and topology (head.c) ---- */

/* Parses a HEAD payload of clen bytes into info (render parameters, expanded topology);
 * info->version_minor says which values the HEAD may hold. */
cnerf_status cn_parse_head(const uint8_t *p, uint32_t clen, cnerf_info *info);

/* A later scene's HEAD (payload p, clen bytes) against the first one's (p0, len0): the same
 * length and topology bytes (CNERF_E_HEADER otherwise), and valid render parameters, which
 * go into info when `record`. */
cnerf_status cn_parse_scene_head(const uint8_t *p, uint32_t clen, const uint8_t *p0,
                                 uint32_t len0, cnerf_info *info, int record);

/* Parses a UNIT payload of clen bytes into info's networks and re-expands the topology. */
cnerf_status cn_parse_units(const uint8_t *p, uint32_t clen, cnerf_info *info);

/* ---- container walk (container.c) ---- */

/* Parses the whole stream into `info`, describing scene `scene` (CNERF_E_ARG after a
 * complete walk when the stream has fewer scenes); used by cnerf_peek and cnerf_open. */
cnerf_status cn_parse(const uint8_t *buf, size_t len, uint32_t scene, cnerf_info *info);

/* 1 when the layer's kernel has a shift term (not every shift 0). */
static inline int cn_has_shift(const cnerf_shift_info *S) { return S->smin != 0 || S->smax != 0; }

/* 1 when this machine stores integers least significant byte first (a packed image's
 * workspace is in the byte order of the machine that packed it). */
static inline int cn_little_endian(void)
{
    const uint16_t one = 1u;
    return *(const unsigned char *)&one == 1u;
}

/* Freestanding memset. */
void cn_memzero(void *p, size_t n);

/* ---- the workspace (open.c) ---- */

/* Points the state's arrays (latents, shifts, biases, rows, the grid and its summary) at
 * their places in the workspace w, by the stream's topology alone, and sets n_pairs.
 * Returns the end of those places: where open's scratch starts, and a packed image's
 * workspace ends. */
uint8_t *cn_lay_out(cnerf_decoder *dec, uint8_t *w);

/* 1 for the layers whose outputs leave the networks (density and colour): the renderer
 * writes them by output index, every other layer's outputs in its stored row order. */
int cn_layer_final(const cnerf_layer_info *L);

#endif /* CNERF_DECODER_INTERNAL_H */
