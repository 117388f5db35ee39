/* The broken-stream table (negcases.h). */
#include "negcases.h"

#include <stdlib.h>
#include <string.h>

#include "testutil.h"

/* ---- a stream as a list of chunks, re-joined with fresh CRCs ---- */
#define MAX_CHUNKS 64
typedef struct chunk {
    uint8_t tag[4];
    uint8_t data[4096];
    uint32_t len;
} chunk;
typedef struct chunks {
    uint8_t sig[8];
    chunk c[MAX_CHUNKS];
    int n;
} chunks;

static uint32_t rd32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static void split(const uint8_t *buf, size_t len, chunks *cs)
{
    memcpy(cs->sig, buf, 8);
    cs->n = 0;
    for (size_t off = 8; off + 12 <= len;) {
        chunk *c = &cs->c[cs->n++];
        memcpy(c->tag, buf + off, 4);
        c->len = rd32(buf + off + 4);
        if (c->len > sizeof c->data || cs->n == MAX_CHUNKS)
            break;
        memcpy(c->data, buf + off + 8, c->len);
        off += 12 + c->len;
    }
}

static void join(const chunks *cs, cn_buf *out)
{
    out->n = 0;
    cn_buf_put(out, cs->sig, 8);
    for (int i = 0; i < cs->n; i++) {
        const chunk *c = &cs->c[i];
        cn_buf_put(out, c->tag, 4);
        cn_buf_u32(out, c->len);
        cn_buf_put(out, c->data, c->len);
        cn_buf_u32(out, cnerf_crc32(cnerf_crc32(0, c->tag, 4), c->data, c->len));
    }
}

static void insert_chunk(chunks *cs, int at, const char *tag, const uint8_t *data, uint32_t len)
{
    memmove(&cs->c[at + 1], &cs->c[at], sizeof(chunk) * (size_t)(cs->n - at));
    cs->n++;
    memcpy(cs->c[at].tag, tag, 4);
    memcpy(cs->c[at].data, data, len);
    cs->c[at].len = len;
}

static void remove_chunk(chunks *cs, int at)
{
    memmove(&cs->c[at], &cs->c[at + 1], sizeof(chunk) * (size_t)(cs->n - at - 1));
    cs->n--;
}

static void put16(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}
static void put32(uint8_t *p, uint32_t v)
{
    put16(p, v);
    put16(p + 2, v >> 16);
}

/* ---- the base stream: two networks, an int16 layer and a constant layer ---- */
static cn_buf base;
static cnerf_info base_info;
enum { L_INT16 = 2, L_CONST = 1, L_CODED = 0 };

int neg_base_make(cn_buf *out, cnerf_info *info)
{
    cnerf_info hdr;
    tu_small_header(&hdr, 3, 6, 1);
    cn_synth s;
    char err[256];
    if (cn_synth_make(&s, &hdr, 77, 2.0, err, sizeof err))
        return -1;
    s.k[L_INT16][0] = 300; /* forces int16 storage */
    cnerf_info topo = hdr;
    if (cnerf_expand_topology(&topo) != CNERF_OK) {
        cn_synth_free(&s);
        return -1;
    }
    for (int i = 0; i < topo.layer[L_CONST].n_in * topo.layer[L_CONST].n_out; i++)
        s.k[L_CONST][i] = -3;
    cn_buf_free(&base);
    memset(&base, 0, sizeof base);
    const int rc = cn_write_stream(&s.src, &base, NULL, err, sizeof err);
    cn_synth_free(&s);
    if (rc || cnerf_peek(base.p, base.n, &base_info) != CNERF_OK ||
        base_info.layer[L_INT16].kmax < 300 || base_info.layer[L_CONST].payload_bytes != 0)
        return -1;
    if (out) {
        memset(out, 0, sizeof *out);
        cn_buf_put(out, base.p, base.n);
    }
    if (info)
        *info = base_info;
    return 0;
}

void neg_base_free(void) { cn_buf_free(&base); }

/* Offsets inside chunk payloads. */
#define HEAD 0
#define LAYR(l) (1 + (l))
#define DONE (1 + (int)base_info.n_layers)
#define H_COORD 0
#define H_LPOS 1
#define H_FLAGS 3
#define H_NEAR 4
#define H_FAR 8
#define H_AABB 12
#define H_NCOARSE 39
#define H_NFINE 41
#define H_NNETS 43
#define H_NET0 44
#define Y_INDEX 1
#define Y_NIN 2
#define Y_F_IN 6
#define Y_A_M 7
#define Y_A_E 10
#define Y_BIAS_BITS 15
#define Y_BIAS_E 16

static uint32_t lay_rel(unsigned l, uint32_t abs_off)
{
    return abs_off - (base_info.layer[l].chunk_offset + 8);
}
/* kmin of layer l, relative to its chunk payload. */
static uint32_t y_kmin(unsigned l) { return lay_rel(l, base_info.layer[l].bias_offset) +
                                            ((base_info.layer[l].n_out * base_info.layer[l].bias_bits + 7u) >> 3); }

/* ---- the cases ---- */
static void e_major1(chunks *c) { put16(c->sig + 4, 1); }
static void e_major3(chunks *c) { put16(c->sig + 4, 3); }
static void e_minor(chunks *c) { put16(c->sig + 6, 7); }
static void e_magic(chunks *c) { c->sig[1] = 'X'; }
static void e_width(chunks *c) { put16(c->c[HEAD].data + H_NET0 + 1, CNERF_MAX_WIDTH + 1); }
static void e_depth17(chunks *c) { c->c[HEAD].data[H_NET0] = CNERF_MAX_DEPTH + 1; }
static void e_depth0(chunks *c) { c->c[HEAD].data[H_NET0] = 0; }
static void e_lpos(chunks *c) { c->c[HEAD].data[H_LPOS] = CNERF_MAX_L_POS + 1; }
static void e_ncoarse0(chunks *c) { put16(c->c[HEAD].data + H_NCOARSE, 0); }
static void e_ncoarse_big(chunks *c) { put16(c->c[HEAD].data + H_NCOARSE, CNERF_MAX_SAMPLES + 1); }
static void e_nnets3(chunks *c) { c->c[HEAD].data[H_NNETS] = 3; }
static void e_near_far(chunks *c) { put32(c->c[HEAD].data + H_NEAR, 6u << 16); }
static void e_neg_near(chunks *c) { put32(c->c[HEAD].data + H_NEAR, (uint32_t)-65536); }
static void e_coord(chunks *c) { c->c[HEAD].data[H_COORD] = 2; }
static void e_ndc_near(chunks *c) { c->c[HEAD].data[H_COORD] = CNERF_COORD_NDC; }
static void e_flags(chunks *c) { c->c[HEAD].data[H_FLAGS] |= 0x80; }
static void e_nets_mismatch(chunks *c) { put16(c->c[HEAD].data + H_NFINE, 0); }
static void e_skip(chunks *c) { c->c[HEAD].data[H_NET0 + 3] = 2; /* depth 3: no later layer */ }
static void e_aabb(chunks *c) { memcpy(c->c[HEAD].data + H_AABB + 12, c->c[HEAD].data + H_AABB, 4); }
static void e_head_long(chunks *c) { c->c[HEAD].len++; }
static void e_head_short(chunks *c) { c->c[HEAD].len = 20; }
static void e_nin(chunks *c) { put16(c->c[LAYR(0)].data + Y_NIN, 7); }
static void e_index(chunks *c) { c->c[LAYR(2)].data[Y_INDEX] = 3; }
static void e_kmin_gt_kmax(chunks *c)
{
    uint8_t *k = c->c[LAYR(L_CODED)].data + y_kmin(L_CODED);
    uint8_t t[2] = {k[0], k[1]};
    k[0] = k[2];
    k[1] = k[3];
    k[2] = t[0];
    k[3] = t[1];
}
static void e_kmin_limit(chunks *c) { put16(c->c[LAYR(L_CODED)].data + y_kmin(L_CODED), 0x8000); }
static void e_a_exp(chunks *c) { c->c[LAYR(0)].data[Y_A_E] = 64; }
static void e_a_mant(chunks *c)
{
    uint8_t *p = c->c[LAYR(0)].data + Y_A_M;
    p[0] = 0;
    p[1] = 0;
    p[2] = 0x80; /* -2^23 */
}
static void e_f_low(chunks *c) { c->c[LAYR(0)].data[Y_F_IN] = (uint8_t)(CNERF_F_MIN - 1); }
static void e_f_high(chunks *c) { c->c[LAYR(0)].data[Y_F_IN] = CNERF_F_MAX + 1; }
static void e_bias_bits(chunks *c) { c->c[LAYR(0)].data[Y_BIAS_BITS] = 25; }
static void e_bias_exp0(chunks *c)
{
    c->c[LAYR(0)].data[Y_BIAS_BITS] = 0;
    c->c[LAYR(0)].data[Y_BIAS_E] = 1;
}
static uint8_t *prec_byte(chunks *c) { return c->c[LAYR(L_CODED)].data + y_kmin(L_CODED) + 4; }
static void e_prec0(chunks *c) { *prec_byte(c) = 0; }
static void e_prec17(chunks *c) { *prec_byte(c) = 17; }
static void e_order16(chunks *c) { prec_byte(c)[1] = 16; }
static void e_prec_lower(chunks *c) { (*prec_byte(c))--; }
static void e_prec_higher(chunks *c) { (*prec_byte(c))++; }
static void e_prec_too_small(chunks *c) { *prec_byte(c) = 1; }
static void e_table_empty(chunks *c) { c->c[LAYR(L_CODED)].len = y_kmin(L_CODED) + 6; }
static void e_payload_short(chunks *c)
{
    const cnerf_layer_info *L = &base_info.layer[L_CODED];
    c->c[LAYR(L_CODED)].len = lay_rel(L_CODED, L->payload_offset) + 3;
}
static void e_payload_byte(chunks *c)
{
    const cnerf_layer_info *L = &base_info.layer[L_CODED];
    c->c[LAYR(L_CODED)].data[lay_rel(L_CODED, L->payload_offset) + L->payload_bytes / 2] ^= 0x10;
}
static void e_payload_extra(chunks *c) { c->c[LAYR(L_CODED)].data[c->c[LAYR(L_CODED)].len++] = 0; }
static void e_const_payload(chunks *c) { c->c[LAYR(L_CONST)].data[c->c[LAYR(L_CONST)].len++] = 0; }
static void e_int16_payload(chunks *c)
{
    const cnerf_layer_info *L = &base_info.layer[L_INT16];
    c->c[LAYR(L_INT16)].data[lay_rel(L_INT16, L->payload_offset) + 5] ^= 0x01;
}
static void e_unknown_critical(chunks *c) { insert_chunk(c, 1, "XTRA", (const uint8_t *)"ab", 2); }
static void e_unknown_ancillary(chunks *c) { insert_chunk(c, 1, "xtra", (const uint8_t *)"ab", 2); }
static void e_meta_before_head(chunks *c) { insert_chunk(c, 0, "meta", (const uint8_t *)"x", 1); }
static void e_bad_tag(chunks *c) { c->c[LAYR(0)].tag[1] = '4'; }
static void e_head_not_first(chunks *c)
{
    chunk t = c->c[0];
    c->c[0] = c->c[1];
    c->c[1] = t;
}
static void e_dup_head(chunks *c) { insert_chunk(c, 1, "HEAD", c->c[0].data, c->c[0].len); }
static void e_missing_layer(chunks *c) { remove_chunk(c, LAYR(2)); }
static void e_extra_layer(chunks *c)
{
    insert_chunk(c, DONE, "LAYR", c->c[DONE - 1].data, c->c[DONE - 1].len);
}
static void e_missing_done(chunks *c) { remove_chunk(c, DONE); }
static void e_done_payload(chunks *c) { c->c[DONE].len = 1; }
static void e_no_chunks(chunks *c) { c->n = 0; }

/* ---- occupancy grids ---- */

/* A valid GRID payload of g^3 cells (a ball in the middle) into chunk-sized data. */
static uint32_t grid_payload(uint32_t g, uint8_t *data)
{
    uint8_t occ[8 * 8 * 8];
    for (uint32_t i = 0; i < g * g * g; i++) {
        const int x = (int)(i % g) * 2 - (int)g + 1, y = (int)(i / g % g) * 2 - (int)g + 1,
                  z = (int)(i / g / g) * 2 - (int)g + 1;
        occ[i] = x * x + y * y + z * z <= (int)(g * g);
    }
    cn_buf b = {0};
    if (g > 8 || cn_grid_encode(occ, g, CN_GRID_PREC, &b) || b.n > sizeof(((chunk *)0)->data)) {
        cn_buf_free(&b);
        return 0;
    }
    memcpy(data, b.p, b.n);
    const uint32_t n = (uint32_t)b.n;
    cn_buf_free(&b);
    return n;
}

/* Inserts a grid of g cells after HEAD (chunk 1). */
static chunk *add_grid(chunks *c, uint32_t g)
{
    uint8_t data[256];
    const uint32_t n = grid_payload(g, data);
    insert_chunk(c, 1, "GRID", data, n);
    return &c->c[1];
}
static void e_grid_ok(chunks *c) { add_grid(c, 4); }
static void e_grid_g0(chunks *c) { add_grid(c, 4)->data[0] = 0; }
static void e_grid_g129(chunks *c) { add_grid(c, 4)->data[0] = CNERF_MAX_GRID + 1; }
static void e_grid_size(chunks *c) { add_grid(c, 4)->data[0] = 5; }
static void e_grid_prec0(chunks *c) { add_grid(c, 4)->data[1] = 0; }
static void e_grid_prec17(chunks *c) { add_grid(c, 4)->data[1] = CNERF_MAX_PREC + 1; }
static void e_grid_f0(chunks *c) { put16(add_grid(c, 4)->data + 2 + 2 * 3, 0); }
static void e_grid_fmax(chunks *c) { put16(add_grid(c, 4)->data + 2 + 2 * 5, 1u << CN_GRID_PREC); }
static void e_grid_cut(chunks *c) { add_grid(c, 4)->len = CNERF_GRID_FIXED_BYTES - 1; }
static void e_grid_short(chunks *c) { add_grid(c, 4)->len = CNERF_GRID_FIXED_BYTES + 3; }
static void e_grid_byte(chunks *c) { add_grid(c, 4)->data[CNERF_GRID_FIXED_BYTES + 4] ^= 0x04; }
static void e_grid_extra(chunks *c)
{
    chunk *g = add_grid(c, 4);
    g->data[g->len++] = 0;
}
static void e_grid_twice(chunks *c)
{
    add_grid(c, 4);
    insert_chunk(c, 2, "GRID", c->c[1].data, c->c[1].len);
}
/* Moves chunk 1 (just inserted after HEAD) behind the first layer: HEAD, LAYR 0, chunk. */
static void behind_first_layer(chunks *c)
{
    chunk t = c->c[1];
    c->c[1] = c->c[2];
    c->c[2] = t;
}
static void e_grid_after_layer(chunks *c)
{
    add_grid(c, 4);
    behind_first_layer(c);
}

/* ---- units per layer ---- */

/* Inserts after HEAD a UNIT chunk that keeps every layer's full width (valid: the same
 * topology, spelled out). */
static chunk *add_units(chunks *c)
{
    uint8_t data[64];
    uint32_t n = 0;
    for (unsigned net = 0; net < base_info.n_nets; net++) {
        const cnerf_net_info *N = &base_info.net[net];
        for (unsigned i = 0; i < N->depth; i++, n += 2)
            put16(data + n, N->width);
        if (N->view_width)
            put16(data + n, N->view_width), n += 2;
    }
    insert_chunk(c, 1, "UNIT", data, n);
    return &c->c[1];
}
static void e_units_ok(chunks *c) { add_units(c); }
/* Trunk layer 1 of the coarse network said to have one unit fewer than its LAYR has. */
static void e_units_layer(chunks *c) { put16(add_units(c)->data + 2, base_info.net[0].width - 1); }
static void e_units_zero(chunks *c) { put16(add_units(c)->data + 2, 0); }
static void e_units_wide(chunks *c) { put16(add_units(c)->data + 2, base_info.net[0].width + 1); }
static void e_units_view_wide(chunks *c)
{
    put16(add_units(c)->data + 2 * base_info.net[0].depth, base_info.net[0].view_width + 1);
}
static void e_units_short(chunks *c) { add_units(c)->len -= 2; }
static void e_units_long(chunks *c)
{
    chunk *u = add_units(c);
    put16(u->data + u->len, 1);
    u->len += 2;
}
static void e_units_twice(chunks *c)
{
    add_units(c);
    insert_chunk(c, 2, "UNIT", c->c[1].data, c->c[1].len);
}
static void e_units_after_grid(chunks *c)
{
    add_units(c);
    add_grid(c, 4); /* HEAD, GRID, UNIT */
}
static void e_units_after_layer(chunks *c)
{
    add_units(c);
    behind_first_layer(c);
}

/* Raw edits after joining (no CRC repair). */
static void r_trailing(cn_buf *b) { cn_buf_u8(b, 0); }
static void r_crc(cn_buf *b) { b->p[8 + 8 + base_info.head_bytes - 12] ^= 1; }
static void r_length_huge(cn_buf *b) { put32(b->p + 8 + 4, 0xFFFFFFF0u); }
static void r_empty(cn_buf *b) { b->n = 0; }
static void r_magic_prefix(cn_buf *b) { b->n = 3; }

const neg_case neg_cases[] = {
    {"wrong magic", e_magic, NULL, CNERF_E_MAGIC, CNERF_E_MAGIC},
    {"major version 1 (format 1.x)", e_major1, NULL, CNERF_E_VERSION, CNERF_E_VERSION},
    {"major version 3", e_major3, NULL, CNERF_E_VERSION, CNERF_E_VERSION},
    {"minor version 7 is accepted", e_minor, NULL, CNERF_OK, CNERF_OK},
    {"width over the limit", e_width, NULL, CNERF_E_LIMIT, CNERF_E_LIMIT},
    {"depth over the limit", e_depth17, NULL, CNERF_E_LIMIT, CNERF_E_LIMIT},
    {"depth 0", e_depth0, NULL, CNERF_E_LIMIT, CNERF_E_LIMIT},
    {"position octaves over the limit", e_lpos, NULL, CNERF_E_LIMIT, CNERF_E_LIMIT},
    {"no coarse samples", e_ncoarse0, NULL, CNERF_E_LIMIT, CNERF_E_LIMIT},
    {"coarse samples over the limit", e_ncoarse_big, NULL, CNERF_E_LIMIT, CNERF_E_LIMIT},
    {"three networks", e_nnets3, NULL, CNERF_E_LIMIT, CNERF_E_LIMIT},
    {"near >= far", e_near_far, NULL, CNERF_E_HEADER, CNERF_E_HEADER},
    {"negative near", e_neg_near, NULL, CNERF_E_HEADER, CNERF_E_HEADER},
    {"unknown coordinate system", e_coord, NULL, CNERF_E_HEADER, CNERF_E_HEADER},
    {"NDC with world near/far", e_ndc_near, NULL, CNERF_E_HEADER, CNERF_E_HEADER},
    {"unknown encoding flag", e_flags, NULL, CNERF_E_HEADER, CNERF_E_HEADER},
    {"two networks but no fine samples", e_nets_mismatch, NULL, CNERF_E_HEADER, CNERF_E_HEADER},
    {"skip into no later layer", e_skip, NULL, CNERF_E_HEADER, CNERF_E_HEADER},
    {"empty scene bounds", e_aabb, NULL, CNERF_E_HEADER, CNERF_E_HEADER},
    {"HEAD one byte long", e_head_long, NULL, CNERF_E_CHUNK, CNERF_E_CHUNK},
    {"HEAD cut short", e_head_short, NULL, CNERF_E_CHUNK, CNERF_E_CHUNK},
    {"layer width mismatch", e_nin, NULL, CNERF_E_LAYER, CNERF_E_LAYER},
    {"layer index out of order", e_index, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER},
    {"kmin > kmax", e_kmin_gt_kmax, NULL, CNERF_E_RANGE, CNERF_E_RANGE},
    {"kmin -32768", e_kmin_limit, NULL, CNERF_E_RANGE, CNERF_E_RANGE},
    {"affine exponent 64", e_a_exp, NULL, CNERF_E_FORMAT, CNERF_E_FORMAT},
    {"affine mantissa -2^23", e_a_mant, NULL, CNERF_E_FORMAT, CNERF_E_FORMAT},
    {"input scale below the range", e_f_low, NULL, CNERF_E_FORMAT, CNERF_E_FORMAT},
    {"input scale above the range", e_f_high, NULL, CNERF_E_FORMAT, CNERF_E_FORMAT},
    {"bias bits 25", e_bias_bits, NULL, CNERF_E_FORMAT, CNERF_E_FORMAT},
    {"zero-bit biases with an exponent", e_bias_exp0, NULL, CNERF_E_FORMAT, CNERF_E_FORMAT},
    {"table precision 0", e_prec0, NULL, CNERF_E_TABLE, CNERF_E_TABLE},
    {"table precision 17", e_prec17, NULL, CNERF_E_TABLE, CNERF_E_TABLE},
    {"Exp-Golomb order 16", e_order16, NULL, CNERF_E_TABLE, CNERF_E_TABLE},
    {"frequencies exceed the precision", e_prec_lower, NULL, CNERF_E_TABLE, CNERF_E_TABLE},
    {"frequencies fall short (payload mismatch)", e_prec_higher, NULL, CNERF_OK, CNERF_E_PAYLOAD},
    {"alphabet larger than 2^prec", e_prec_too_small, NULL, CNERF_E_TABLE, CNERF_E_TABLE},
    {"empty table", e_table_empty, NULL, CNERF_E_TABLE, CNERF_E_TABLE},
    {"payload under 4 bytes", e_payload_short, NULL, CNERF_E_PAYLOAD, CNERF_E_PAYLOAD},
    {"payload byte changed, CRC fixed", e_payload_byte, NULL, CNERF_OK, CNERF_E_PAYLOAD},
    {"payload with an extra byte", e_payload_extra, NULL, CNERF_OK, CNERF_E_PAYLOAD},
    {"int16 payload bit changed", e_int16_payload, NULL, CNERF_OK, CNERF_E_PAYLOAD},
    {"constant layer with payload", e_const_payload, NULL, CNERF_E_CHUNK, CNERF_E_CHUNK},
    {"unknown critical chunk", e_unknown_critical, NULL, CNERF_E_UNKNOWN_CHUNK,
     CNERF_E_UNKNOWN_CHUNK},
    {"unknown ancillary chunk is skipped", e_unknown_ancillary, NULL, CNERF_OK, CNERF_OK},
    {"ancillary chunk before HEAD", e_meta_before_head, NULL, CNERF_E_CHUNK_ORDER,
     CNERF_E_CHUNK_ORDER},
    {"tag not letters", e_bad_tag, NULL, CNERF_E_CHUNK, CNERF_E_CHUNK},
    {"HEAD not first", e_head_not_first, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER},
    {"duplicate HEAD", e_dup_head, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER},
    {"missing layer", e_missing_layer, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER},
    {"extra layer", e_extra_layer, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER},
    {"missing DONE", e_missing_done, NULL, CNERF_E_TRUNCATED, CNERF_E_TRUNCATED},
    {"DONE with a payload", e_done_payload, NULL, CNERF_E_CHUNK, CNERF_E_CHUNK},
    {"signature only", e_no_chunks, NULL, CNERF_E_TRUNCATED, CNERF_E_TRUNCATED},
    {"grid is accepted", e_grid_ok, NULL, CNERF_OK, CNERF_OK},
    {"grid of 0 cells", e_grid_g0, NULL, CNERF_E_LIMIT, CNERF_E_LIMIT},
    {"grid over the limit", e_grid_g129, NULL, CNERF_E_LIMIT, CNERF_E_LIMIT},
    {"grid size disagrees with its payload", e_grid_size, NULL, CNERF_OK, CNERF_E_PAYLOAD},
    {"grid precision 0", e_grid_prec0, NULL, CNERF_E_TABLE, CNERF_E_TABLE},
    {"grid precision 17", e_grid_prec17, NULL, CNERF_E_TABLE, CNERF_E_TABLE},
    {"grid frequency 0", e_grid_f0, NULL, CNERF_E_TABLE, CNERF_E_TABLE},
    {"grid frequency 2^prec", e_grid_fmax, NULL, CNERF_E_TABLE, CNERF_E_TABLE},
    {"grid chunk cut in its tables", e_grid_cut, NULL, CNERF_E_CHUNK, CNERF_E_CHUNK},
    {"grid payload under 4 bytes", e_grid_short, NULL, CNERF_E_PAYLOAD, CNERF_E_PAYLOAD},
    {"grid payload byte changed, CRC fixed", e_grid_byte, NULL, CNERF_OK, CNERF_E_PAYLOAD},
    {"grid payload with an extra byte", e_grid_extra, NULL, CNERF_OK, CNERF_E_PAYLOAD},
    {"two grids", e_grid_twice, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER},
    {"grid after a layer", e_grid_after_layer, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER},
    {"units are accepted", e_units_ok, NULL, CNERF_OK, CNERF_OK},
    {"units disagree with the layers", e_units_layer, NULL, CNERF_E_LAYER, CNERF_E_LAYER},
    {"a layer of 0 units", e_units_zero, NULL, CNERF_E_HEADER, CNERF_E_HEADER},
    {"more units than the width", e_units_wide, NULL, CNERF_E_HEADER, CNERF_E_HEADER},
    {"more view units than the view width", e_units_view_wide, NULL, CNERF_E_HEADER,
     CNERF_E_HEADER},
    {"UNIT chunk cut short", e_units_short, NULL, CNERF_E_CHUNK, CNERF_E_CHUNK},
    {"UNIT chunk too long", e_units_long, NULL, CNERF_E_CHUNK, CNERF_E_CHUNK},
    {"two UNIT chunks", e_units_twice, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER},
    {"units after the grid", e_units_after_grid, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER},
    {"units after a layer", e_units_after_layer, NULL, CNERF_E_CHUNK_ORDER,
     CNERF_E_CHUNK_ORDER},
    {"trailing byte", NULL, r_trailing, CNERF_E_TRAILING, CNERF_E_TRAILING},
    {"HEAD CRC flipped", NULL, r_crc, CNERF_E_CRC, CNERF_E_CRC},
    {"chunk length past the end", NULL, r_length_huge, CNERF_E_TRUNCATED, CNERF_E_TRUNCATED},
    {"empty input", NULL, r_empty, CNERF_E_TRUNCATED, CNERF_E_TRUNCATED},
    {"magic prefix only", NULL, r_magic_prefix, CNERF_E_TRUNCATED, CNERF_E_TRUNCATED},
};

const size_t neg_case_count = sizeof neg_cases / sizeof neg_cases[0];

int neg_build(size_t i, cn_buf *out)
{
    static chunks cs;
    if (i >= neg_case_count || !base.p)
        return -1;
    const neg_case *t = &neg_cases[i];
    split(base.p, base.n, &cs);
    if (t->edit)
        t->edit(&cs);
    memset(out, 0, sizeof *out);
    join(&cs, out);
    if (t->raw)
        t->raw(out);
    return 0;
}
