/*
 * cnerf_open: the workspace's layout, the latents' and shifts' decoding, the rows' order and
 * packing for the kernels, the per-layer proofs of the fixed-point sums, and the kernels'
 * choice; and the accessors of the decoded matrices (cnerf_latent, cnerf_shift).
 */
#include "../common/cn_fixed.h"
#include "cn_internal.h"
#include "cn_kernels.h"

/* ---- the workspace's size ---- */

static size_t align8(size_t n) { return (n + 7u) & ~(size_t)7u; }

/* Alphabet size of a coded layer, 0 for a constant one. */
static uint32_t alphabet(const cnerf_layer_info *L)
{
    return L->kmin < L->kmax ? (uint32_t)(L->kmax - L->kmin) + 1u : 0u;
}

/* The grid stored by blocks (cn_grid_model.h) needs, for nb = ceil(g / 8) blocks per axis:
 * a u16 record index per block, the summary's levels 3 and up (nb^3 bits and then the
 * levels of that cube: at most 2 nb^3 bits, as the levels of a cube of side 2^n sum to
 * (8^n - 1) / 7 and ceil adds at most that much again) and the records, 73 bytes each: at
 * most 76 nb^3 + 24 bytes with the alignment (CNERF_WORKSPACE_BOUND). */
static uint32_t grid_nb(uint32_t g) { return (g + CN_GRID_B - 1u) / CN_GRID_B; }
static size_t grid_slot_bytes(uint32_t g)
{
    const size_t nb = grid_nb(g);
    return nb * nb * nb * 2u;
}
static size_t grid_summary_bytes(uint32_t g)
{
    size_t bits = 0;
    for (uint32_t n = grid_nb(g);;) {
        bits += (size_t)n * n * n;
        if (n <= 1u)
            break;
        n = (n + 1u) >> 1;
    }
    return (bits + 7u) >> 3;
}
static size_t grid_bytes(const cnerf_info *info)
{
    const cn_grid_code gc = cn_grid_code_of(info);
    return align8(grid_slot_bytes(gc.g)) + align8(grid_summary_bytes(gc.g)) +
           align8((size_t)gc.recs * CN_GRID_REC_BYTES);
}

/* Inputs of a layer padded to whole pairs (the kernels take two at a time). */
static uint32_t in_pad(const cnerf_layer_info *L) { return ((uint32_t)L->n_in + 1u) & ~1u; }

/* Bytes of one stored latent of layer L: 1 when its range fits int8 and the latents are not
 * all kept as int16 (k16: cnerf_open given cnerf_workspace_size_fast bytes), else 2. */
static unsigned k_bytes_as(const cnerf_layer_info *L, int k16)
{
    return !k16 && cn_latents_s8(L->kmin, L->kmax) ? 1u : 2u;
}
static unsigned k_bytes(const cn_state *ds, const cnerf_layer_info *L)
{
    return k_bytes_as(L, ds->k16);
}

/* Element i of a matrix of int8 (es 1) or int16 (es 2) values. */
static int32_t m_get(const void *m, unsigned es, size_t i)
{
    return es == 1u ? ((const int8_t *)m)[i] : ((const int16_t *)m)[i];
}
static void m_set(void *m, unsigned es, size_t i, int32_t v)
{
    if (es == 1u)
        ((int8_t *)m)[i] = (int8_t)v;
    else
        ((int16_t *)m)[i] = (int16_t)v;
}

/* The workspace with the latents of int8 range stored as int8 (k16 0) or as int16 (1). */
static size_t ws_bytes(const cnerf_info *info, int k16)
{
    if (!info || info->n_layers > CNERF_MAX_LAYERS)
        return 0;
    /* Every term is bounded by the limits (see CNERF_WORKSPACE_BOUND), and the total is
     * below 2^29 bytes, so size_t arithmetic cannot overflow even where it is 32 bits. */
    size_t total = 0, scratch = 0;
    for (uint32_t l = 0; l < info->n_layers; l++) {
        const cnerf_layer_info *L = &info->layer[l];
        const cnerf_shift_info *S = &info->shift[l];
        total += align8((size_t)in_pad(L) * L->n_out * k_bytes_as(L, k16)); /* packed latents */
        if (cn_has_shift(S))
            total += align8((size_t)in_pad(L) * L->n_out * 2u); /* packed int16 shifts */
        total += 2u * align8((size_t)L->n_out * 4u);          /* bias mantissas, bias_q16 */
        total += align8((size_t)L->n_out * 2u);               /* row order */
        /* open's scratch: the frequency table, or four rows while packing them */
        const size_t cum = alphabet(L) ? ((size_t)alphabet(L) + 1u) * 4u : 0u;
        const size_t scum = S->smin < S->smax ? ((size_t)(S->smax - S->smin) + 2u) * 4u : 0u;
        const size_t rows4 = (size_t)in_pad(L) * 4u * 2u;
        scratch = cum > scratch ? cum : scratch;
        scratch = scum > scratch ? scum : scratch;
        scratch = rows4 > scratch ? rows4 : scratch;
    }
    if (info->grid_g)
        total += grid_bytes(info);
    return total + align8(scratch);
}

size_t cnerf_workspace_size(const cnerf_info *info) { return ws_bytes(info, 0); }

size_t cnerf_workspace_size_fast(const cnerf_info *info) { return ws_bytes(info, 1); }

/* ---- a layer's numbers: bias mantissas, latents and shifts ---- */

/* Reads layer L's bias mantissas into `out`. */
static cnerf_status read_biases(const uint8_t *buf, const cnerf_layer_info *L, int32_t *out)
{
    if (L->bias_bits == 0u) {
        for (uint32_t j = 0; j < L->n_out; j++)
            out[j] = 0;
        return CNERF_OK;
    }
    cn_bits b;
    cn_bits_init(&b, buf + L->bias_offset, (L->n_out * (uint32_t)L->bias_bits + 7u) >> 3);
    for (uint32_t j = 0; j < L->n_out; j++)
        out[j] = cn_sext(cn_bits_get(&b, L->bias_bits), L->bias_bits);
    return b.err ? CNERF_E_CHUNK : CNERF_OK; /* cannot fail after cn_parse */
}

/* A coded integer matrix: a layer's latents or its shifts. */
typedef struct coded {
    uint32_t n_in, n_out;
    int32_t lo, hi; /* range; lo == hi codes nothing */
    uint32_t prec, order, table_offset, payload_offset, payload_bytes;
} coded;

static coded coded_latents(const cnerf_layer_info *L)
{
    coded c = {L->n_in, L->n_out, L->kmin, L->kmax, L->prec, L->eg_order, L->table_offset,
               L->payload_offset, L->payload_bytes};
    return c;
}

static coded coded_shifts(const cnerf_layer_info *L, const cnerf_shift_info *S)
{
    coded c = {L->n_in, L->n_out, S->smin, S->smax, S->prec, S->eg_order, S->table_offset,
               S->payload_offset, S->payload_bytes};
    return c;
}

/* Decodes a coded matrix row-major into lat, rows of in_pad elements of es bytes (int8 or
 * int16) with a zero in the pad column. */
static cnerf_status decode_matrix(const uint8_t *buf, const coded *C, void *lat, unsigned es,
                                  uint32_t *cum)
{
    const uint32_t n_in = C->n_in, n_out = C->n_out, pad = (n_in + 1u) & ~1u;
    const uint32_t count = n_in * n_out;
    if (C->lo == C->hi) {
        for (uint32_t i = 0; i < count; i++)
            m_set(lat, es, i, C->lo);
    } else {
        const uint32_t n = (uint32_t)(C->hi - C->lo) + 1u;
        cn_bits b;
        cn_bits_init(&b, buf + C->table_offset, C->payload_offset - C->table_offset);
        cnerf_status st = cn_table_read(&b, n, C->prec, C->order, cum);
        if (st == CNERF_OK)
            st = cn_rans_decode(buf + C->payload_offset, C->payload_bytes, cum, n, C->prec,
                                C->lo, lat, es, count);
        if (st != CNERF_OK)
            return st;
    }
    if (pad != n_in) {
        /* spread the rows to their padded stride, last first (each moves up) */
        for (uint32_t o = n_out; o-- > 0u;) {
            m_set(lat, es, (size_t)o * pad + n_in, 0);
            for (uint32_t i = n_in; i-- > 0u;)
                m_set(lat, es, (size_t)o * pad + i, m_get(lat, es, (size_t)o * n_in + i));
        }
    }
    return CNERF_OK;
}

/* ---- the rows' order, the columns' order and the packing for the kernels ---- */

/* The layout of layer l's packed latents (shift 0) or shifts (shift 1, always int16): the
 * chosen kernels' for int32 sums (for int8 latents their int8 layout), CN_PAIRS for the
 * int64 ones (cn_dot_s16_s64_c, cn_dot_s8_s64_c). */
static uint32_t layout_of(const cnerf_decoder *dec, uint32_t l, int shift)
{
    const cn_state *ds = cn_cstate_of(dec);
    const int wide = shift ? ds->shift_wide[l] != 0 : ds->form[l] == CN_FORM_WIDE;
    if (wide)
        return CN_PAIRS;
    return !shift && k_bytes(ds, &dec->info.layer[l]) == 1u ? ds->layout8 : ds->layout;
}

/* Sum |v| of row o of a padded matrix of es-byte elements (<= 1124 * 32767 < 2^26). */
static uint32_t row_abs_sum(const void *m, unsigned es, uint32_t o, uint32_t pad)
{
    uint32_t sum = 0;
    for (uint32_t i = 0; i < pad; i++) {
        const int32_t k = m_get(m, es, (size_t)o * pad + i);
        sum += (uint32_t)(k < 0 ? -k : k);
    }
    return sum;
}

/* Orders the layer's rows: live ones (a non-zero latent, or a non-zero shift when `sh` is
 * not NULL) first, in increasing output order; rows[] gets each stored row's output index,
 * the all-zero rows last. Puts the largest sum |k| of a row into *maxsum and the largest
 * sum |s| into *maxshift. Returns the live rows. */
static uint16_t order_rows(const cnerf_layer_info *L, const void *lat, unsigned es,
                           const int16_t *sh,
                           uint16_t *rows, uint32_t *maxsum, uint32_t *maxshift)
{
    const uint32_t pad = in_pad(L), n_out = L->n_out;
    uint32_t live = 0, dead = n_out;
    *maxsum = *maxshift = 0;
    for (uint32_t o = 0; o < n_out; o++) {
        const uint32_t sum = row_abs_sum(lat, es, o, pad),
                       ss = sh ? row_abs_sum(sh, 2u, o, pad) : 0u;
        *maxsum = sum > *maxsum ? sum : *maxsum;
        *maxshift = ss > *maxshift ? ss : *maxshift;
        if (sum || ss)
            rows[live++] = (uint16_t)o;
        else
            rows[--dead] = (uint16_t)o; /* fills from the end, in decreasing order */
    }
    return (uint16_t)live;
}

/* Packs the live rows of lat (es-byte elements, in the order of rows[]) into blocks of four
 * in `layout` (cn_packed_index), using `tmp` (4 padded rows), and zeroes the rest. A
 * block's rows come from row slots at or after its own (a live row's output index is at
 * least its rank), so writing block b overwrites only slots that were copied to tmp,
 * belong to earlier blocks or hold zeros. */
static void pack_rows(const cnerf_layer_info *L, void *lat, unsigned es, const uint16_t *rows,
                      uint32_t live, int16_t *tmp, uint32_t layout)
{
    const uint32_t pad = in_pad(L), n_out = L->n_out;
    for (uint32_t b = 0; 4u * b < live; b++) {
        const uint32_t rb = live - 4u * b < 4u ? live - 4u * b : 4u;
        for (uint32_t q = 0; q < rb; q++)
            for (uint32_t i = 0; i < pad; i++)
                tmp[(size_t)q * pad + i] =
                    (int16_t)m_get(lat, es, (size_t)rows[4u * b + q] * pad + i);
        for (uint32_t q = 0; q < rb; q++)
            for (uint32_t i = 0; i < pad; i++)
                m_set(lat, es, cn_packed_index(4u * b + q, i, live, pad / 2u, layout),
                      tmp[(size_t)q * pad + i]);
    }
    for (size_t i = (size_t)live * pad; i < (size_t)n_out * pad; i++)
        m_set(lat, es, i, 0);
}

/* 1 when the live rows of lat (row-major, es-byte elements, in the order of rows[]) are
 * better stored as lists of their non-zero latents for kernels v: the lists cost v less
 * than the packed rows, and they fit in place. Written row after row from the start of the
 * layer's place, the lists of rows 0..j take 4 (j + 1 + their non-zeros) bytes; row j + 1
 * is read from row slot rows[j + 1] >= j + 1, at byte es pad (j + 1) or after: every
 * prefix must end there, so that no row is overwritten before it is read. The workspace is
 * the same either way. */
static int sparse_pays(const cnerf_layer_info *L, const void *lat, unsigned es,
                       const uint16_t *rows, uint32_t live, const cn_dot_variant *v)
{
    const uint32_t pad = in_pad(L);
    uint64_t words = 0, nz = 0;
    for (uint32_t j = 0; j < live; j++) {
        uint32_t n = 0;
        for (uint32_t i = 0; i < pad; i++)
            n += m_get(lat, es, (size_t)rows[j] * pad + i) != 0;
        nz += n;
        words += 1u + n;
        if (4u * words > (uint64_t)(j + 1u) * pad * es)
            return 0;
    }
    return nz * v->nz_cost + (uint64_t)live * v->row_cost <
           (uint64_t)live * pad * (es == 1u ? v->mac8_cost : v->mac_cost);
}

/* Stores the live rows of lat as lists (cn_spdot_fn's layout) in its place, each row first
 * copied to tmp (sparse_pays proved that no row is overwritten before it is read). */
static void sparse_rows(const cnerf_layer_info *L, void *lat, unsigned es, const uint16_t *rows,
                        uint32_t live, int16_t *tmp)
{
    const uint32_t pad = in_pad(L);
    uint32_t *w = (uint32_t *)lat;
    for (uint32_t j = 0; j < live; j++) {
        for (uint32_t i = 0; i < pad; i++)
            tmp[i] = (int16_t)m_get(lat, es, (size_t)rows[j] * pad + i);
        uint32_t *count = w++;
        uint32_t n = 0;
        for (uint32_t i = 0; i < pad; i++)
            if (tmp[i]) {
                *w++ = (2u * i) << 16 | ((uint32_t)(int32_t)tmp[i] & 0xffffu);
                n++;
            }
        *count = n;
    }
}

/* The layer whose outputs feed layer l's inputs from column *off on (the renderer keeps
 * every layer's outputs in its stored row order, [fixed-point.md]: the consumer's columns
 * follow that order), or -1 when l's inputs are all encodings. */
static int producer(const cnerf_info *I, uint32_t l, uint32_t *off)
{
    const cnerf_layer_info *L = &I->layer[l];
    const cnerf_net_info *N = &I->net[L->net];
    const int first = N->first_layer, D = N->depth;
    *off = 0;
    switch (L->role) {
    case CNERF_ROLE_TRUNK:
        if (L->index == 0u)
            return -1;
        if (N->skip != CNERF_NO_SKIP && L->index == N->skip + 1u)
            *off = I->in_pos;
        return first + L->index - 1;
    case CNERF_ROLE_SIGMA:
    case CNERF_ROLE_FEATURE:
    case CNERF_ROLE_OUTPUT:
        return first + D - 1;
    case CNERF_ROLE_VIEW:
        return first + D + 1; /* the feature */
    default:
        return first + D + 2; /* rgb: the view layer */
    }
}

/* 1 for the layers whose outputs leave the networks (density, colour, or both): they are
 * written by output index; every other layer's in its stored row order. */
int cn_layer_final(const cnerf_layer_info *L)
{
    return L->role == CNERF_ROLE_SIGMA || L->role == CNERF_ROLE_RGB ||
           L->role == CNERF_ROLE_OUTPUT;
}

/* Reorders layer l's input columns (es-byte elements) from its producer's outputs into the
 * producer's stored row order: column off + j takes column off + rows_p[j]. tmp holds one
 * row. */
static void order_columns(const cnerf_decoder *dec, uint32_t l, void *lat, unsigned es,
                          int16_t *tmp)
{
    const cn_state *ds = cn_cstate_of(dec);
    uint32_t off;
    const int p = producer(&dec->info, l, &off);
    if (p < 0)
        return;
    const cnerf_layer_info *L = &dec->info.layer[l];
    const uint32_t pad = in_pad(L), U = dec->info.layer[p].n_out;
    const uint16_t *rows = ds->rows[p];
    for (uint32_t o = 0; o < L->n_out; o++) {
        const size_t row = (size_t)o * pad + off;
        for (uint32_t j = 0; j < U; j++)
            tmp[j] = (int16_t)m_get(lat, es, row + rows[j]);
        for (uint32_t j = 0; j < U; j++)
            m_set(lat, es, row + j, tmp[j]);
    }
}

/* ---- the Q16 biases and the proofs of the fixed-point sums ---- */

/* sat32(round(v)) of the rounding rule of the layers (half up). */
static int32_t q16_bias(int32_t m, int e)
{
    return (int32_t)cn_clamp64(cn_mul_exp_r(m, 1, e + 16, 1), INT32_MIN, INT32_MAX);
}

/* The per-layer proofs of docs/fixed-point.md. |sum k x_q| of a row is at most
 * 2^15 S, S its sum |k|; with every row's S <= 65535 it is below 2^31 (an int32 sum). The
 * rescale round(acc a_m 2^-n) of such a sum needs no saturation when 2^15 max S |a_m| <
 * 2^(30+n): it stays below 2^30 in magnitude. */
static void prove_layer(cnerf_decoder *dec, uint32_t l, uint32_t maxsum, uint32_t maxshift)
{
    cn_state *ds = cn_state_of(dec);
    const cnerf_layer_info *L = &dec->info.layer[l];
    ds->form[l] = maxsum > 65535u ? CN_FORM_WIDE : CN_FORM_PACKED;
    ds->shift_wide[l] = maxshift > 65535u; /* the same bound for the sums s x_q */
    const int n = -((int)L->a_e + 16 - (int)L->f_in);
    const uint64_t am = (uint64_t)(L->a_m < 0 ? -L->a_m : L->a_m); /* < 2^23 */
    const uint64_t bound = ((uint64_t)maxsum << 15) * am;           /* < 2^16 2^15 2^23 */
    ds->a_shift[l] = 0;
    /* A layer with a shift adds its term before the offset and bias: the general path. */
    if (ds->form[l] != CN_FORM_WIDE && !ds->shift[l] && n >= 1 && n <= 62 && (bound >> 30) >> n == 0u)
        ds->a_shift[l] = (uint8_t)n;
    /* b sum x_q: |sum x_q| <= 2^15 n_in */
    const int nb = -((int)L->b_e + 16 - (int)L->f_in);
    const uint64_t bm = (uint64_t)(L->b_m < 0 ? -L->b_m : L->b_m);
    const uint64_t bbound = ((uint64_t)L->n_in << 15) * bm; /* < 2^11 2^15 2^23 */
    ds->b_shift[l] = 0;
    if (nb >= 1 && nb <= 62 && (bbound >> 30) >> nb == 0u)
        ds->b_shift[l] = (uint8_t)nb;
}

/* ---- the grid's summary ---- */

/* Sets bit i of bits. */
static void set_bit(uint8_t *bits, uint32_t i) { bits[i >> 3] = (uint8_t)(bits[i >> 3] | (1u << (i & 7u))); }

/* The summary of the grid stored by blocks: in each record, levels 1 and 2 from its cells;
 * a block without an occupied cell loses its record (GRID gives every block one), and level
 * 3, one bit per block, is set for the others; then each level above from the one below,
 * one after another bit by bit from `out`. */
static void build_summary(uint32_t g, uint16_t *slot, uint8_t *rec, uint8_t *out)
{
    const uint32_t nb = grid_nb(g);
    cn_memzero(out, grid_summary_bytes(g));
    for (uint32_t b = 0; b < nb * nb * nb; b++) {
        const uint32_t r = slot[b];
        if (r == CN_GRID_NO_BLOCK)
            continue;
        const uint32_t base = r * CN_GRID_REC_BITS;
        uint32_t any = 0;
        for (uint32_t l = 0; l < 512u; l++) {
            /* a record starts at a bit offset of 8 r: whole bytes, so a row of 8 cells is
             * one byte, skipped at once when empty */
            if (!(l & 7u) && !rec[(base + l) >> 3]) {
                l += 7u;
                continue;
            }
            if (!cn_grid_bit(rec, base + l))
                continue;
            const uint32_t x = l & 7u, y = (l >> 3) & 7u, z = l >> 6;
            set_bit(rec, base + 512u + (((z >> 1) * 4u + (y >> 1)) * 4u + (x >> 1)));
            set_bit(rec, base + 576u + (((z >> 2) * 2u + (y >> 2)) * 2u + (x >> 2)));
            any = 1;
        }
        if (any)
            set_bit(out, b);
        else
            slot[b] = (uint16_t)CN_GRID_NO_BLOCK;
    }
    uint32_t src_off = 0, n = nb, dst_off = nb * nb * nb;
    while (n > 1u) {
        const uint32_t m = (n + 1u) >> 1;
        for (uint32_t z = 0; z < n; z++)
            for (uint32_t y = 0; y < n; y++)
                for (uint32_t x = 0; x < n; x++)
                    if (cn_grid_bit(out, src_off + (z * n + y) * n + x))
                        set_bit(out, dst_off + ((z >> 1) * m + (y >> 1)) * m + (x >> 1));
        src_off = dst_off;
        dst_off += m * m * m;
        n = m;
    }
}

/* ---- cnerf_open ---- */

/* The workspace's layout (cn_internal.h): per layer its packed latents (and shifts), bias
 * mantissas, Q16 biases and row order; then the grid's record indices, summary and
 * records. */
uint8_t *cn_lay_out(cnerf_decoder *dec, uint8_t *w)
{
    cn_state *ds = cn_state_of(dec);
    const cnerf_info *info = &dec->info;
    for (uint32_t l = 0; l < info->n_layers; l++) {
        const cnerf_layer_info *L = &info->layer[l];
        ds->latent[l] = w;
        w += align8((size_t)in_pad(L) * L->n_out * k_bytes(ds, L));
        if (cn_has_shift(&info->shift[l])) {
            ds->shift[l] = (const int16_t *)(void *)w;
            w += align8((size_t)in_pad(L) * L->n_out * 2u);
        }
        ds->bias[l] = (const int32_t *)(void *)w;
        w += align8((size_t)L->n_out * 4u);
        ds->bias_q16[l] = (const int32_t *)(void *)w;
        w += align8((size_t)L->n_out * 4u);
        ds->rows[l] = (const uint16_t *)(void *)w;
        w += align8((size_t)L->n_out * 2u);
        ds->n_pairs[l] = (uint16_t)(in_pad(L) / 2u);
    }
    if (info->grid_g) {
        ds->grid_slot = (const uint16_t *)(void *)w;
        w += align8(grid_slot_bytes(info->grid_g));
        ds->grid_summary = w;
        w += align8(grid_summary_bytes(info->grid_g));
        ds->grid_rec = w;
        ds->grid_recs = cn_grid_code_of(info).recs;
        w += align8((size_t)ds->grid_recs * CN_GRID_REC_BYTES);
    }
    return w;
}

/* Decodes layer l into its place in the workspace: the bias mantissas; the latents (and
 * shifts) widened to int16, their columns in the producer's row order, the live rows first
 * and packed for the kernels; the Q16 biases in row order; and the layer's proofs. */
static cnerf_status open_layer(cnerf_decoder *dec, const uint8_t *buf, uint32_t l,
                               uint8_t *scratch, const cn_dot_variant *v)
{
    cn_state *ds = cn_state_of(dec);
    const cnerf_layer_info *L = &dec->info.layer[l];
    int32_t *bias = (int32_t *)(uintptr_t)ds->bias[l];
    void *lat = (void *)(uintptr_t)ds->latent[l];
    const unsigned es = k_bytes(ds, L);
    uint16_t *rows = (uint16_t *)(uintptr_t)ds->rows[l];
    int16_t *sh = (int16_t *)(uintptr_t)ds->shift[l]; /* NULL: no shift */
    int16_t *tmp = (int16_t *)(void *)scratch;
    const coded ck = coded_latents(L), cs = coded_shifts(L, &dec->info.shift[l]);
    cnerf_status st = read_biases(buf, L, bias);
    if (st == CNERF_OK)
        st = decode_matrix(buf, &ck, lat, es, (uint32_t *)(void *)scratch);
    if (st == CNERF_OK && sh)
        st = decode_matrix(buf, &cs, sh, 2u, (uint32_t *)(void *)scratch);
    if (st != CNERF_OK)
        return st;
    order_columns(dec, l, lat, es, tmp);
    if (sh)
        order_columns(dec, l, sh, 2u, tmp);
    uint32_t maxsum, maxshift;
    const uint16_t live = order_rows(L, lat, es, sh, rows, &maxsum, &maxshift);
    ds->n_live[l] = live;
    prove_layer(dec, l, maxsum, maxshift);
    /* a layer with a shift, or with int64 sums, stays packed */
    if (!sh && ds->form[l] == CN_FORM_PACKED && live &&
        sparse_pays(L, lat, es, rows, live, v)) {
        sparse_rows(L, lat, es, rows, live, tmp);
        ds->form[l] = CN_FORM_SPARSE;
    } else {
        pack_rows(L, lat, es, rows, live, tmp, layout_of(dec, l, 0));
        if (sh)
            pack_rows(L, sh, 2u, rows, live, tmp, layout_of(dec, l, 1));
    }
    int32_t *bq = (int32_t *)(uintptr_t)ds->bias_q16[l];
    for (uint32_t j = 0; j < L->n_out; j++)
        bq[j] = L->bias_bits ? q16_bias(bias[rows[j]], L->bias_e) : 0;
    return CNERF_OK;
}

cnerf_status cn_open_with(cnerf_decoder *dec, const uint8_t *buf, size_t len, uint32_t scene,
                          void *ws, size_t ws_size, const cn_dot_variant *v, int fast)
{
    if (!dec)
        return CNERF_E_NULL;
    cn_memzero(dec, sizeof *dec);
    if ((!buf && len) || !ws)
        return CNERF_E_NULL;
    if ((uintptr_t)ws & (CNERF_WS_ALIGN - 1u))
        return CNERF_E_WS_ALIGN;
    if (!buf)
        buf = (const uint8_t *)""; /* no bytes: an empty stream */
    const cnerf_info *info = &dec->info;
    cn_state *ds = cn_state_of(dec);
    cnerf_status st = cn_parse(buf, len, scene, &dec->info);
    if (st == CNERF_OK && ws_size < cnerf_workspace_size(info))
        st = CNERF_E_WS_SMALL;
    if (st == CNERF_OK) {
        /* Latents of int8 range kept as int16 where the kernels sum those faster and the
         * caller gave the room: the same sums, so the same pixels. */
        ds->k16 = (uint8_t)(fast && v->mac8_cost > v->mac_cost &&
                            ws_size >= cnerf_workspace_size_fast(info));
        ds->layout = v->layout;
        ds->layout8 = v->layout8;
        /* the layers' arrays, the grid, and open's scratch last */
        uint8_t *scratch = cn_lay_out(dec, (uint8_t *)ws);
        if (info->grid_g) {
            const cn_grid_code gc = cn_grid_code_of(info);
            uint16_t *slot = (uint16_t *)(uintptr_t)ds->grid_slot;
            uint8_t *rec = (uint8_t *)(uintptr_t)ds->grid_rec;
            st = cn_grid_decode(buf + info->grid_payload_offset, info->grid_payload_bytes, &gc,
                                slot, rec, &ds->grid_occupied);
            if (st == CNERF_OK)
                build_summary(gc.g, slot, rec, (uint8_t *)(uintptr_t)ds->grid_summary);
        }
        for (uint32_t l = 0; st == CNERF_OK && l < info->n_layers; l++)
            st = open_layer(dec, buf, l, scratch, v);
    }
    if (st == CNERF_OK) {
        ds->dot = v->fn;
        ds->dot8 = v->fn8;
        ds->spdot = v->spdot;
        ds->requant = v->requant;
        ds->finish = v->finish;
    }
    if (st != CNERF_OK)
        cn_memzero(dec, sizeof *dec);
    return st;
}

cnerf_status cnerf_open_scene(cnerf_decoder *dec, const uint8_t *buf, size_t len,
                              uint32_t scene, void *ws, size_t ws_size)
{
    const cn_dot_variant v = cn_dot_select();
    return cn_open_with(dec, buf, len, scene, ws, ws_size, &v, 1);
}

cnerf_status cnerf_open(cnerf_decoder *dec, const uint8_t *buf, size_t len, void *ws,
                        size_t ws_size)
{
    return cnerf_open_scene(dec, buf, len, 0, ws, ws_size);
}

/* ---- packed images (cnerf_open_packed; cnerf_pack in tools.c writes them) ---- */

/* Sum |k| over the live row j of a packed layer: n elements of es bytes in `layout`. */
static uint32_t packed_row_sum(const void *m, unsigned es, uint32_t j, uint32_t live,
                               uint32_t pairs, uint32_t layout)
{
    uint32_t sum = 0;
    for (uint32_t i = 0; i < 2u * pairs; i++) {
        const int32_t k = m_get(m, es, cn_packed_index(j, i, live, pairs, layout));
        sum += (uint32_t)(k < 0 ? -k : k);
    }
    return sum;
}

/* Layer l of an image: its row order must be a permutation of its outputs, its lists (a
 * sparse layer) must lie in the layer's place with inputs in range, and the proofs of its
 * sums, made again from the image's latents, must give the form and the shifts' width
 * that the image states (form, shift_wide): then the kernels read only what they would
 * read from cnerf_open's workspace, and no sum leaves its accumulator. */
static cnerf_status packed_layer(cnerf_decoder *dec, uint32_t l, uint32_t live, uint32_t form,
                                 uint32_t shift_wide)
{
    cn_state *ds = cn_state_of(dec);
    const cnerf_layer_info *L = &dec->info.layer[l];
    const uint32_t n_out = L->n_out, pad = in_pad(L), pairs = pad / 2u;
    const unsigned es = k_bytes(ds, L);
    if (live > n_out || form > CN_FORM_SPARSE || shift_wide > 1u ||
        (shift_wide && !ds->shift[l]) || (form == CN_FORM_SPARSE && ds->shift[l]))
        return CNERF_E_IMAGE;
    uint8_t seen[((CNERF_MAX_WIDTH > CNERF_MAX_VIEW_WIDTH ? CNERF_MAX_WIDTH
                                                          : CNERF_MAX_VIEW_WIDTH) + 7u) / 8u];
    cn_memzero(seen, sizeof seen);
    for (uint32_t j = 0; j < n_out; j++) {
        const uint32_t o = ds->rows[l][j];
        if (o >= n_out || o >= 8u * sizeof seen || ((uint32_t)seen[o >> 3] >> (o & 7u)) & 1u)
            return CNERF_E_IMAGE;
        seen[o >> 3] = (uint8_t)(seen[o >> 3] | 1u << (o & 7u));
    }
    ds->n_live[l] = (uint16_t)live;
    ds->form[l] = (uint8_t)form;
    ds->shift_wide[l] = (uint8_t)shift_wide;
    uint32_t maxsum = 0, maxshift = 0;
    if (form == CN_FORM_SPARSE) {
        const uint32_t *e = (const uint32_t *)ds->latent[l];
        const size_t words = (size_t)pad * n_out * es / 4u; /* the layer's place */
        size_t at = 0;
        for (uint32_t j = 0; j < live; j++) {
            if (at >= words || e[at] > pad || e[at] > words - at - 1u)
                return CNERF_E_IMAGE;
            const uint32_t n = e[at++];
            uint32_t sum = 0;
            for (uint32_t k = 0; k < n; k++, at++) {
                if (e[at] >> 17 >= pad || (e[at] >> 16 & 1u))
                    return CNERF_E_IMAGE;
                const int32_t v = cn_entry_k(e[at]);
                sum += (uint32_t)(v < 0 ? -v : v);
            }
            maxsum = sum > maxsum ? sum : maxsum;
        }
    } else {
        for (uint32_t j = 0; j < live; j++) {
            const uint32_t sum = packed_row_sum(ds->latent[l], es, j, live, pairs,
                                                layout_of(dec, l, 0));
            const uint32_t ss = ds->shift[l] ? packed_row_sum(ds->shift[l], 2u, j, live, pairs,
                                                              layout_of(dec, l, 1))
                                             : 0u;
            maxsum = sum > maxsum ? sum : maxsum;
            maxshift = ss > maxshift ? ss : maxshift;
        }
    }
    prove_layer(dec, l, maxsum, maxshift);
    if (ds->form[l] != (form == CN_FORM_SPARSE ? CN_FORM_PACKED : form) ||
        ds->shift_wide[l] != shift_wide)
        return CNERF_E_IMAGE;
    ds->form[l] = (uint8_t)form;
    return CNERF_OK;
}

/* cnerf_open_packed's checks of the header, in the order of cnerf.h; the state's layouts
 * from it. */
static cnerf_status packed_header(cnerf_decoder *dec, const uint8_t *im, size_t len,
                                  const cn_dot_variant *v)
{
    if ((uintptr_t)im & (CNERF_WS_ALIGN - 1u))
        return CNERF_E_IMAGE_ALIGN;
    if (len < 4u || im[0] != 'C' || im[1] != 'N' || im[2] != 'P' || im[3] != 'K')
        return len < 4u ? CNERF_E_TRUNCATED : CNERF_E_MAGIC;
    if (len < CNERF_IMAGE_HEADER_BYTES)
        return CNERF_E_TRUNCATED;
    if (cn_le16(im + 4) != CNERF_IMAGE_VERSION)
        return CNERF_E_IMAGE_VERSION;
    uint32_t i = 0;
    while (i < 8u && v->name[i] && im[8 + i] == (uint8_t)v->name[i])
        i++;
    if (im[6] != (cn_little_endian() ? 'L' : 'B') || (i < 8u && (v->name[i] || im[8 + i])) ||
        im[16] != v->layout || im[17] != v->layout8)
        return CNERF_E_IMAGE_TARGET;
    const uint32_t total = cn_le32(im + 24);
    if (total < CNERF_IMAGE_HEADER_BYTES)
        return CNERF_E_IMAGE;
    if (total > len)
        return CNERF_E_TRUNCATED;
    uint32_t crc = cnerf_crc32(0, im, 44u);
    crc = cnerf_crc32(crc, im + 48, total - 48u);
    if (crc != cn_le32(im + 44))
        return CNERF_E_IMAGE_CRC;
    const uint32_t n_layers = im[7], ws_off = cn_le32(im + 28), ws_len = cn_le32(im + 32),
                   s_off = cn_le32(im + 36), s_len = cn_le32(im + 40);
    /* each part inside the image, in order, none wrapping around */
    if (n_layers > CNERF_MAX_LAYERS || ws_off < CNERF_IMAGE_HEADER_BYTES + 4u * n_layers ||
        (ws_off & (CNERF_WS_ALIGN - 1u)) || ws_off > total || ws_len > total - ws_off ||
        s_off < ws_off + ws_len || s_off > total || s_len > total - s_off)
        return CNERF_E_IMAGE;
    cn_state *ds = cn_state_of(dec);
    ds->layout = v->layout;
    ds->layout8 = v->layout8;
    return CNERF_OK;
}

cnerf_status cn_open_packed_with(cnerf_decoder *dec, const uint8_t *image, size_t len,
                                 const cn_dot_variant *vp)
{
    if (!dec)
        return CNERF_E_NULL;
    cn_memzero(dec, sizeof *dec);
    if (!image)
        return CNERF_E_NULL;
    const cn_dot_variant v = *vp;
    cnerf_status st = packed_header(dec, image, len, &v);
    const uint8_t *im = image;
    if (st == CNERF_OK)
        st = cn_parse(im + cn_le32(im + 36), cn_le32(im + 40), cn_le32(im + 20), &dec->info);
    cn_state *ds = cn_state_of(dec);
    const cnerf_info *info = &dec->info;
    if (st == CNERF_OK && info->n_layers != im[7])
        st = CNERF_E_IMAGE;
    if (st == CNERF_OK) {
        /* The state points into the image, which the decoder only reads. */
        uint8_t *ws = (uint8_t *)(uintptr_t)(im + cn_le32(im + 28));
        if ((size_t)(cn_lay_out(dec, ws) - ws) != cn_le32(im + 32))
            st = CNERF_E_IMAGE;
    }
    for (uint32_t l = 0; st == CNERF_OK && l < info->n_layers; l++) {
        const uint8_t *p = im + CNERF_IMAGE_HEADER_BYTES + 4u * l;
        st = packed_layer(dec, l, cn_le16(p), p[2], p[3]);
    }
    if (st == CNERF_OK && info->grid_g) {
        /* every record index in range (or none), and the occupied cells counted */
        const uint32_t nb = grid_nb(info->grid_g);
        for (uint32_t b = 0; st == CNERF_OK && b < nb * nb * nb; b++) {
            const uint32_t r = ds->grid_slot[b];
            if (r != CN_GRID_NO_BLOCK && r >= ds->grid_recs)
                st = CNERF_E_IMAGE;
            for (uint32_t l = 0; st == CNERF_OK && r != CN_GRID_NO_BLOCK && l < 512u; l++)
                ds->grid_occupied += cn_grid_rec_bit(ds->grid_rec, r, l);
        }
    }
    if (st == CNERF_OK) {
        ds->dot = v.fn;
        ds->dot8 = v.fn8;
        ds->spdot = v.spdot;
        ds->requant = v.requant;
        ds->finish = v.finish;
    } else {
        cn_memzero(dec, sizeof *dec);
    }
    return st;
}

cnerf_status cnerf_open_packed(cnerf_decoder *dec, const uint8_t *image, size_t len)
{
    const cn_dot_variant v = cn_dot_select();
    return cn_open_packed_with(dec, image, len, &v);
}

/* ---- the decoded matrices, for tools and tests ---- */

/* Element (o, i) of layer l's packed matrix m (its latents or its shifts). */
static int32_t packed_at(const cnerf_decoder *dec, uint32_t l, const void *m, uint32_t o,
                         uint32_t i)
{
    const cn_state *ds = cn_cstate_of(dec);
    const cnerf_layer_info *L = &dec->info.layer[l];
    if (o >= L->n_out || i >= L->n_in || !m)
        return 0;
    /* Live rows are stored first, in increasing output order (order_rows): a search, since
     * this accessor is for tools and tests, not for rendering. */
    uint32_t j = 0;
    while (j < ds->n_live[l] && ds->rows[l][j] != o)
        j++;
    if (j == ds->n_live[l])
        return 0; /* an all-zero row */
    uint32_t off, c = i;
    const int p = producer(&dec->info, l, &off);
    if (p >= 0 && i >= off && i - off < dec->info.layer[p].n_out) {
        c = off; /* the column of input i: its producer's stored row */
        while (ds->rows[p][c - off] != i - off)
            c++;
    }
    if (m == ds->latent[l] && ds->form[l] == CN_FORM_SPARSE) {
        const uint32_t *e = (const uint32_t *)(const void *)m;
        for (uint32_t r = 0; r < j; r++) /* the lists of the rows stored before */
            e += 1u + e[0];
        for (uint32_t k = 1; k <= e[0]; k++)
            if (e[k] >> 17 == c)
                return cn_entry_k(e[k]);
        return 0;
    }
    const int shift = m != ds->latent[l];
    return m_get(m, shift ? 2u : k_bytes(ds, L), cn_packed_index(j, c, ds->n_live[l], ds->n_pairs[l],
                                                             layout_of(dec, l, shift)));
}

int32_t cnerf_latent(const cnerf_decoder *dec, uint32_t l, uint32_t o, uint32_t i)
{
    return dec && l < dec->info.n_layers ? packed_at(dec, l, cn_cstate_of(dec)->latent[l], o, i)
                                         : 0;
}

int32_t cnerf_shift(const cnerf_decoder *dec, uint32_t l, uint32_t o, uint32_t i)
{
    return dec && l < dec->info.n_layers ? packed_at(dec, l, cn_cstate_of(dec)->shift[l], o, i)
                                         : 0;
}

int32_t cnerf_bias(const cnerf_decoder *dec, uint32_t l, uint32_t o)
{
    if (!dec || l >= dec->info.n_layers || o >= dec->info.layer[l].n_out)
        return 0;
    const int32_t *b = cn_cstate_of(dec)->bias[l];
    return b ? b[o] : 0;
}

int cnerf_cell_occupied(const cnerf_decoder *dec, uint32_t c)
{
    if (!dec)
        return 0;
    const uint32_t g = dec->info.grid_g;
    const cn_state *ds = cn_cstate_of(dec);
    if (!g || !ds->grid_slot)
        return 1;
    if (c >= g * g * g)
        return 0;
    return (int)cn_grid_block_bit(ds->grid_slot, ds->grid_rec, grid_nb(g), 0, c % g, c / g % g,
                                  c / g / g);
}

/* The state fits cnerf_decoder's opaque part (C99 has no static assertion: an array of
 * negative size does not compile). */
typedef char cn_state_fits[sizeof(cn_state) <= CNERF_DECODER_OPAQUE_BYTES ? 1 : -1];
