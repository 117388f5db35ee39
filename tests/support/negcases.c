/* The broken-stream table (negcases.h). */
#include "negcases.h"
#include "cn_reader.h"

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

static void split(const uint8_t *buf, size_t len, chunks *cs)
{
    memcpy(cs->sig, buf, 8);
    cs->n = 0;
    for (size_t off = 8; off + 12 <= len;) {
        chunk *c = &cs->c[cs->n++];
        memcpy(c->tag, buf + off, 4);
        c->len = cn_le32(buf + off + 4);
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
static int set_base_make(void);

int neg_base_make(cn_buf *out, cnerf_info *info)
{
    cnerf_info hdr;
    tu_small_header(&hdr, 3, 6, 1);
    cn_synth s;
    char err[256];
    if (tu_synth(&s, &hdr, 77, 2.0, err, sizeof err))
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
    return set_base_make();
}

/* ---- the two-scene base stream: the same topology, shifts in every layer ---- */
static cn_buf set_base;

static int set_base_make(void)
{
    cnerf_info hdr;
    tu_small_header(&hdr, 3, 6, 1);
    cn_synth s[2];
    cn_synth_shift sh;
    char err[256];
    if (tu_synth(&s[0], &hdr, 77, 2.0, err, sizeof err))
        return -1;
    hdr.background[1] = 40;
    if (tu_synth(&s[1], &hdr, 78, 2.0, err, sizeof err)) {
        cn_synth_free(&s[0]);
        return -1;
    }
    int rc = cn_synth_shift_make(&sh, &s[0], 79, 1.0, 0.5, err, sizeof err);
    const cn_stream_src src[2] = {s[0].src, s[1].src};
    cn_buf_free(&set_base);
    memset(&set_base, 0, sizeof set_base);
    if (rc == 0) {
        rc = cn_write_set(src, 2, sh.src, &set_base, NULL, NULL, err, sizeof err);
        cn_synth_shift_free(&sh);
    }
    cn_synth_free(&s[0]);
    cn_synth_free(&s[1]);
    return rc;
}

void neg_base_free(void)
{
    cn_buf_free(&base);
    cn_buf_free(&set_base);
}

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
static void e_coord(chunks *c) { c->c[HEAD].data[H_COORD] = CNERF_COORD_CONTRACT + 1; }
static void e_contract_v20(chunks *c) { c->c[HEAD].data[H_COORD] = CNERF_COORD_CONTRACT; }
static void e_contract_ok(chunks *c) /* 2.2, bounds the cube [-2, 2]^3 */
{
    put16(c->sig + 6, CNERF_VERSION_MINOR_CONTRACT);
    c->c[HEAD].data[H_COORD] = CNERF_COORD_CONTRACT;
    for (int a = 0; a < 3; a++) {
        put32(c->c[HEAD].data + H_AABB + 4 * a, (uint32_t)(-2 * 65536));
        put32(c->c[HEAD].data + H_AABB + 12 + 4 * a, 2u << 16);
    }
}
static void e_contract_box(chunks *c)
{
    e_contract_ok(c);
    put32(c->c[HEAD].data + H_AABB + 20, 3u << 16);
}
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

/* A valid GRID (blocks 0) or BGRD (blocks 1) payload of g^3 cells (a ball in the middle)
 * into chunk-sized data. */
static uint32_t grid_payload(uint32_t g, int blocks, uint8_t *data)
{
    uint8_t occ[16 * 16 * 16];
    for (uint32_t i = 0; i < g * g * g; i++) {
        const int x = (int)(i % g) * 2 - (int)g + 1, y = (int)(i / g % g) * 2 - (int)g + 1,
                  z = (int)(i / g / g) * 2 - (int)g + 1;
        occ[i] = x * x + y * y + z * z <= (int)(g * g);
    }
    cn_buf b = {0};
    if (g > 16 ||
        (blocks ? cn_grid_encode(occ, g, CN_GRID_PREC, &b)
                : cn_grid_encode_raster(occ, g, CN_GRID_PREC, &b)) ||
        b.n > sizeof(((chunk *)0)->data)) {
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
    const uint32_t n = grid_payload(g, 0, data);
    insert_chunk(c, 1, "GRID", data, n);
    return &c->c[1];
}
/* The same coded by blocks (BGRD), in a stream stamped 2.3. */
static chunk *add_bgrd(chunks *c, uint32_t g)
{
    uint8_t data[256];
    const uint32_t n = grid_payload(g, 1, data);
    insert_chunk(c, 1, "BGRD", data, n);
    put16(c->sig + 6, CNERF_VERSION_MINOR_BLOCKS);
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
static void e_bgrd_ok(chunks *c) { add_bgrd(c, 12); }
static void e_bgrd_old(chunks *c)
{
    add_bgrd(c, 12);
    put16(c->sig + 6, CNERF_VERSION_MINOR_BLOCKS - 1);
}
static void e_bgrd_g0(chunks *c) { add_bgrd(c, 12)->data[0] = 0; }
static void e_bgrd_blocks(chunks *c) { put16(add_bgrd(c, 12)->data + 2, 9); } /* 2^3 blocks */
static void e_bgrd_fewer(chunks *c) { put16(add_bgrd(c, 12)->data + 2, 1); }
static void e_bgrd_size(chunks *c) { add_bgrd(c, 12)->data[0] = 20; }
static void e_bgrd_fb0(chunks *c) { put16(add_bgrd(c, 12)->data + 4 + 2 * 2, 0); }
static void e_bgrd_f0(chunks *c)
{
    put16(add_bgrd(c, 12)->data + 4 + 2 * CNERF_GRID_CONTEXTS + 2 * 6, 0);
}
static void e_bgrd_cut(chunks *c) { add_bgrd(c, 12)->len = CNERF_BGRD_FIXED_BYTES - 1; }
static void e_bgrd_short(chunks *c) { add_bgrd(c, 12)->len = CNERF_BGRD_FIXED_BYTES + 3; }
static void e_bgrd_twice(chunks *c)
{
    add_bgrd(c, 12);
    insert_chunk(c, 2, "GRID", c->c[1].data, c->c[1].len);
    uint8_t data[256];
    const uint32_t n = grid_payload(4, 0, data);
    memcpy(c->c[2].data, data, n);
    c->c[2].len = n;
}
static void e_bgrd_after_layer(chunks *c)
{
    add_bgrd(c, 12);
    behind_first_layer(c);
}

/* ---- levels ---- */

/* A levl chunk declaring level L right after HEAD (chunk 1), in a stream stamped 2.3. */
static chunk *add_level(chunks *c, uint8_t L)
{
    insert_chunk(c, 1, "levl", &L, 1);
    put16(c->sig + 6, CNERF_VERSION_MINOR_BLOCKS);
    return &c->c[1];
}
static void e_level_ok(chunks *c) { add_level(c, 1); }
static void e_level_unknown(chunks *c) { add_level(c, CNERF_MAX_LEVELS + 6); }
static void e_level_zero(chunks *c) { add_level(c, 0); }
static void e_level_long(chunks *c) { add_level(c, 1)->len = 2; }
static void e_level_late(chunks *c)
{
    add_level(c, 1);
    behind_first_layer(c);
}
static void e_level_twice(chunks *c)
{
    add_level(c, 1);
    add_level(c, 1);
}
/* 200 coarse samples, over level 1's 128 */
static void e_level_exceeded(chunks *c)
{
    add_level(c, 1);
    put16(c->c[HEAD].data + H_NCOARSE, 200);
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

/* ---- several scenes (edits of set_base) ---- */

/* Chunks of the set: HEAD, SCNS, SHFT x n, LAYR x n (scene 0), HEAD, LAYR x n, DONE. */
#define NL ((int)base_info.n_layers)
#define S_SCNS 1
#define S_SHFT(l) (2 + (l))
#define S_LAYR0(l) (2 + NL + (l))
#define S_HEAD1 (2 + 2 * NL)
#define S_LAYR1(l) (3 + 2 * NL + (l))
/* SHFT payload offsets: net, index, n_in, n_out, g_m, g_e, smin, smax, prec. */
#define F_NOUT 4
#define F_G_E 9
#define F_SMIN 10
#define F_PREC 14

static void e_set_ok(chunks *c) { (void)c; }
static void e_set_shape(chunks *c)
{
    uint8_t *n = c->c[S_SHFT(0)].data + F_NOUT;
    put16(n, (uint32_t)(n[0] | n[1] << 8) + 1u);
}
static void e_set_missing_shift(chunks *c) { remove_chunk(c, S_SHFT(NL - 1)); }
static void e_set_no_scns(chunks *c) { remove_chunk(c, S_SCNS); }
static void e_set_count0(chunks *c) { c->c[S_SCNS].data[0] = 0; }
static void e_set_count_long(chunks *c) { c->c[S_SCNS].data[c->c[S_SCNS].len++] = 0; }
static void e_set_count3(chunks *c) { c->c[S_SCNS].data[0] = 3; }
static void e_set_count1(chunks *c) { c->c[S_SCNS].data[0] = 1; }
static void e_set_two_scns(chunks *c)
{
    insert_chunk(c, S_SCNS + 1, "SCNS", c->c[S_SCNS].data, c->c[S_SCNS].len);
}
static void e_set_topology(chunks *c) { put16(c->c[S_HEAD1].data + H_NET0 + 1, 7); }
static void e_set_render(chunks *c) { put32(c->c[S_HEAD1].data + H_NEAR, 6u << 16); }
static void e_set_early_head(chunks *c)
{
    chunk t = c->c[S_HEAD1];
    c->c[S_HEAD1] = c->c[S_HEAD1 - 1];
    c->c[S_HEAD1 - 1] = t;
}
static void e_set_g_exp(chunks *c) { c->c[S_SHFT(0)].data[F_G_E] = 64; }
static void e_set_range(chunks *c)
{
    uint8_t *k = c->c[S_SHFT(0)].data + F_SMIN;
    uint8_t t[2] = {k[0], k[1]};
    k[0] = k[2], k[1] = k[3], k[2] = t[0], k[3] = t[1];
}
static void e_set_prec0(chunks *c) { c->c[S_SHFT(0)].data[F_PREC] = 0; }
static void e_set_units_late(chunks *c)
{
    add_units(c); /* after HEAD, before SCNS: moved behind the first SHFT */
    chunk u = c->c[1];
    remove_chunk(c, 1);
    insert_chunk(c, S_SHFT(1), "UNIT", u.data, u.len);
}
static void e_set_shift_payload(chunks *c)
{
    chunk *f = &c->c[S_SHFT(0)];
    f->data[f->len - 3] ^= 0x10;
}
static void e_set_scene1_payload(chunks *c)
{
    chunk *y = &c->c[S_LAYR1(L_CODED)];
    y->data[y->len - 3] ^= 0x10;
}

/* Raw edits after joining (no CRC repair). */
static void r_trailing(cn_buf *b) { cn_buf_u8(b, 0); }
static void r_crc(cn_buf *b) { b->p[8 + 8 + base_info.head_bytes - 12] ^= 1; }
static void r_length_huge(cn_buf *b) { put32(b->p + 8 + 4, 0xFFFFFFF0u); }
static void r_empty(cn_buf *b) { b->n = 0; }
static void r_magic_prefix(cn_buf *b) { b->n = 3; }

const neg_case neg_cases[] = {
    {"wrong magic", e_magic, NULL, CNERF_E_MAGIC, CNERF_E_MAGIC, 0, 0},
    {"major version 1 (format 1.x)", e_major1, NULL, CNERF_E_VERSION, CNERF_E_VERSION, 0, 0},
    {"major version 3", e_major3, NULL, CNERF_E_VERSION, CNERF_E_VERSION, 0, 0},
    {"minor version 7 is accepted", e_minor, NULL, CNERF_OK, CNERF_OK, 0, 0},
    {"width over the limit", e_width, NULL, CNERF_E_LIMIT, CNERF_E_LIMIT, 0, 0},
    {"depth over the limit", e_depth17, NULL, CNERF_E_LIMIT, CNERF_E_LIMIT, 0, 0},
    {"depth 0", e_depth0, NULL, CNERF_E_LIMIT, CNERF_E_LIMIT, 0, 0},
    {"position octaves over the limit", e_lpos, NULL, CNERF_E_LIMIT, CNERF_E_LIMIT, 0, 0},
    {"no coarse samples", e_ncoarse0, NULL, CNERF_E_LIMIT, CNERF_E_LIMIT, 0, 0},
    {"coarse samples over the limit", e_ncoarse_big, NULL, CNERF_E_LIMIT, CNERF_E_LIMIT, 0, 0},
    {"three networks", e_nnets3, NULL, CNERF_E_LIMIT, CNERF_E_LIMIT, 0, 0},
    {"near >= far", e_near_far, NULL, CNERF_E_HEADER, CNERF_E_HEADER, 0, 0},
    {"negative near", e_neg_near, NULL, CNERF_E_HEADER, CNERF_E_HEADER, 0, 0},
    {"unknown coordinate system", e_coord, NULL, CNERF_E_HEADER, CNERF_E_HEADER, 0, 0},
    {"NDC with world near/far", e_ndc_near, NULL, CNERF_E_HEADER, CNERF_E_HEADER, 0, 0},
    {"unknown encoding flag", e_flags, NULL, CNERF_E_HEADER, CNERF_E_HEADER, 0, 0},
    {"two networks but no fine samples", e_nets_mismatch, NULL, CNERF_E_HEADER, CNERF_E_HEADER, 0, 0},
    {"skip into no later layer", e_skip, NULL, CNERF_E_HEADER, CNERF_E_HEADER, 0, 0},
    {"empty scene bounds", e_aabb, NULL, CNERF_E_HEADER, CNERF_E_HEADER, 0, 0},
    {"HEAD one byte long", e_head_long, NULL, CNERF_E_CHUNK, CNERF_E_CHUNK, 0, 0},
    {"HEAD cut short", e_head_short, NULL, CNERF_E_CHUNK, CNERF_E_CHUNK, 0, 0},
    {"layer width mismatch", e_nin, NULL, CNERF_E_LAYER, CNERF_E_LAYER, 0, 0},
    {"layer index out of order", e_index, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER, 0, 0},
    {"kmin > kmax", e_kmin_gt_kmax, NULL, CNERF_E_RANGE, CNERF_E_RANGE, 0, 0},
    {"kmin -32768", e_kmin_limit, NULL, CNERF_E_RANGE, CNERF_E_RANGE, 0, 0},
    {"affine exponent 64", e_a_exp, NULL, CNERF_E_FORMAT, CNERF_E_FORMAT, 0, 0},
    {"affine mantissa -2^23", e_a_mant, NULL, CNERF_E_FORMAT, CNERF_E_FORMAT, 0, 0},
    {"input scale below the range", e_f_low, NULL, CNERF_E_FORMAT, CNERF_E_FORMAT, 0, 0},
    {"input scale above the range", e_f_high, NULL, CNERF_E_FORMAT, CNERF_E_FORMAT, 0, 0},
    {"bias bits 25", e_bias_bits, NULL, CNERF_E_FORMAT, CNERF_E_FORMAT, 0, 0},
    {"zero-bit biases with an exponent", e_bias_exp0, NULL, CNERF_E_FORMAT, CNERF_E_FORMAT, 0, 0},
    {"table precision 0", e_prec0, NULL, CNERF_E_TABLE, CNERF_E_TABLE, 0, 0},
    {"table precision 17", e_prec17, NULL, CNERF_E_TABLE, CNERF_E_TABLE, 0, 0},
    {"Exp-Golomb order 16", e_order16, NULL, CNERF_E_TABLE, CNERF_E_TABLE, 0, 0},
    {"frequencies exceed the precision", e_prec_lower, NULL, CNERF_E_TABLE, CNERF_E_TABLE, 0, 0},
    {"frequencies fall short (payload mismatch)", e_prec_higher, NULL, CNERF_OK, CNERF_E_PAYLOAD, 0, 0},
    {"alphabet larger than 2^prec", e_prec_too_small, NULL, CNERF_E_TABLE, CNERF_E_TABLE, 0, 0},
    {"empty table", e_table_empty, NULL, CNERF_E_TABLE, CNERF_E_TABLE, 0, 0},
    {"payload under 4 bytes", e_payload_short, NULL, CNERF_E_PAYLOAD, CNERF_E_PAYLOAD, 0, 0},
    {"payload byte changed, CRC fixed", e_payload_byte, NULL, CNERF_OK, CNERF_E_PAYLOAD, 0, 0},
    {"payload with an extra byte", e_payload_extra, NULL, CNERF_OK, CNERF_E_PAYLOAD, 0, 0},
    {"int16 payload bit changed", e_int16_payload, NULL, CNERF_OK, CNERF_E_PAYLOAD, 0, 0},
    {"constant layer with payload", e_const_payload, NULL, CNERF_E_CHUNK, CNERF_E_CHUNK, 0, 0},
    {"unknown critical chunk", e_unknown_critical, NULL, CNERF_E_UNKNOWN_CHUNK,
     CNERF_E_UNKNOWN_CHUNK, 0, 0},
    {"unknown ancillary chunk is skipped", e_unknown_ancillary, NULL, CNERF_OK, CNERF_OK, 0, 0},
    {"ancillary chunk before HEAD", e_meta_before_head, NULL, CNERF_E_CHUNK_ORDER,
     CNERF_E_CHUNK_ORDER, 0, 0},
    {"tag not letters", e_bad_tag, NULL, CNERF_E_CHUNK, CNERF_E_CHUNK, 0, 0},
    {"HEAD not first", e_head_not_first, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER, 0, 0},
    {"duplicate HEAD", e_dup_head, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER, 0, 0},
    {"missing layer", e_missing_layer, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER, 0, 0},
    {"extra layer", e_extra_layer, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER, 0, 0},
    {"missing DONE", e_missing_done, NULL, CNERF_E_TRUNCATED, CNERF_E_TRUNCATED, 0, 0},
    {"DONE with a payload", e_done_payload, NULL, CNERF_E_CHUNK, CNERF_E_CHUNK, 0, 0},
    {"signature only", e_no_chunks, NULL, CNERF_E_TRUNCATED, CNERF_E_TRUNCATED, 0, 0},
    {"grid is accepted", e_grid_ok, NULL, CNERF_OK, CNERF_OK, 0, 0},
    {"grid of 0 cells", e_grid_g0, NULL, CNERF_E_LIMIT, CNERF_E_LIMIT, 0, 0},
    {"grid over the limit", e_grid_g129, NULL, CNERF_E_LIMIT, CNERF_E_LIMIT, 0, 0},
    {"grid size disagrees with its payload", e_grid_size, NULL, CNERF_OK, CNERF_E_PAYLOAD, 0, 0},
    {"grid precision 0", e_grid_prec0, NULL, CNERF_E_TABLE, CNERF_E_TABLE, 0, 0},
    {"grid precision 17", e_grid_prec17, NULL, CNERF_E_TABLE, CNERF_E_TABLE, 0, 0},
    {"grid frequency 0", e_grid_f0, NULL, CNERF_E_TABLE, CNERF_E_TABLE, 0, 0},
    {"grid frequency 2^prec", e_grid_fmax, NULL, CNERF_E_TABLE, CNERF_E_TABLE, 0, 0},
    {"grid chunk cut in its tables", e_grid_cut, NULL, CNERF_E_CHUNK, CNERF_E_CHUNK, 0, 0},
    {"grid payload under 4 bytes", e_grid_short, NULL, CNERF_E_PAYLOAD, CNERF_E_PAYLOAD, 0, 0},
    {"grid payload byte changed, CRC fixed", e_grid_byte, NULL, CNERF_OK, CNERF_E_PAYLOAD, 0, 0},
    {"grid payload with an extra byte", e_grid_extra, NULL, CNERF_OK, CNERF_E_PAYLOAD, 0, 0},
    {"two grids", e_grid_twice, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER, 0, 0},
    {"grid after a layer", e_grid_after_layer, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER, 0, 0},
    {"units are accepted", e_units_ok, NULL, CNERF_OK, CNERF_OK, 0, 0},
    {"units disagree with the layers", e_units_layer, NULL, CNERF_E_LAYER, CNERF_E_LAYER, 0, 0},
    {"a layer of 0 units", e_units_zero, NULL, CNERF_E_HEADER, CNERF_E_HEADER, 0, 0},
    {"more units than the width", e_units_wide, NULL, CNERF_E_HEADER, CNERF_E_HEADER, 0, 0},
    {"more view units than the view width", e_units_view_wide, NULL, CNERF_E_HEADER,
     CNERF_E_HEADER, 0, 0},
    {"UNIT chunk cut short", e_units_short, NULL, CNERF_E_CHUNK, CNERF_E_CHUNK, 0, 0},
    {"UNIT chunk too long", e_units_long, NULL, CNERF_E_CHUNK, CNERF_E_CHUNK, 0, 0},
    {"two UNIT chunks", e_units_twice, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER, 0, 0},
    {"units after the grid", e_units_after_grid, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER, 0, 0},
    {"units after a layer", e_units_after_layer, NULL, CNERF_E_CHUNK_ORDER,
     CNERF_E_CHUNK_ORDER, 0, 0},
    {"trailing byte", NULL, r_trailing, CNERF_E_TRAILING, CNERF_E_TRAILING, 0, 0},
    {"HEAD CRC flipped", NULL, r_crc, CNERF_E_CRC, CNERF_E_CRC, 0, 0},
    {"chunk length past the end", NULL, r_length_huge, CNERF_E_TRUNCATED, CNERF_E_TRUNCATED, 0, 0},
    {"empty input", NULL, r_empty, CNERF_E_TRUNCATED, CNERF_E_TRUNCATED, 0, 0},
    {"magic prefix only", NULL, r_magic_prefix, CNERF_E_TRUNCATED, CNERF_E_TRUNCATED, 0, 0},
    {"set of two scenes is accepted", e_set_ok, NULL, CNERF_OK, CNERF_OK, 1, 0},
    {"scene index out of range", e_set_ok, NULL, CNERF_E_ARG, CNERF_E_ARG, 1, 2},
    {"shift shape disagrees with its layer", e_set_shape, NULL, CNERF_E_LAYER, CNERF_E_LAYER, 1,
     0},
    {"a missing shared shift layer", e_set_missing_shift, NULL, CNERF_E_CHUNK_ORDER,
     CNERF_E_CHUNK_ORDER, 1, 0},
    {"shifts without a scene count", e_set_no_scns, NULL, CNERF_E_CHUNK_ORDER,
     CNERF_E_CHUNK_ORDER, 1, 0},
    {"scene count 0", e_set_count0, NULL, CNERF_E_LIMIT, CNERF_E_LIMIT, 1, 0},
    {"SCNS chunk two bytes long", e_set_count_long, NULL, CNERF_E_CHUNK, CNERF_E_CHUNK, 1, 0},
    {"fewer scenes than the count", e_set_count3, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER,
     1, 0},
    {"more scenes than the count", e_set_count1, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER,
     1, 0},
    {"two SCNS chunks", e_set_two_scns, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER, 1, 0},
    {"second scene of another topology", e_set_topology, NULL, CNERF_E_HEADER, CNERF_E_HEADER, 1,
     0},
    {"second scene with near >= far", e_set_render, NULL, CNERF_E_HEADER, CNERF_E_HEADER, 1, 0},
    {"second scene before the first one's last layer", e_set_early_head, NULL,
     CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER, 1, 0},
    {"shift scale exponent 64", e_set_g_exp, NULL, CNERF_E_FORMAT, CNERF_E_FORMAT, 1, 0},
    {"shift range inverted", e_set_range, NULL, CNERF_E_RANGE, CNERF_E_RANGE, 1, 0},
    {"shift table precision 0", e_set_prec0, NULL, CNERF_E_TABLE, CNERF_E_TABLE, 1, 0},
    {"units after the shifts", e_set_units_late, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER,
     1, 0},
    {"shift payload byte changed", e_set_shift_payload, NULL, CNERF_OK, CNERF_E_PAYLOAD, 1, 0},
    {"second scene's payload changed, opened", e_set_scene1_payload, NULL, CNERF_OK,
     CNERF_E_PAYLOAD, 1, 1},
    {"second scene's payload changed, first opened", e_set_scene1_payload, NULL, CNERF_OK,
     CNERF_OK, 1, 0},
    {"contracted coordinates in a 2.0 stream", e_contract_v20, NULL, CNERF_E_HEADER,
     CNERF_E_HEADER, 0, 0},
    {"contracted coordinates in a 2.2 stream are accepted", e_contract_ok, NULL, CNERF_OK,
     CNERF_OK, 0, 0},
    {"contracted scene whose bounds are not a cube", e_contract_box, NULL, CNERF_E_HEADER,
     CNERF_E_HEADER, 0, 0},
    {"grid by blocks is accepted", e_bgrd_ok, NULL, CNERF_OK, CNERF_OK, 0, 0},
    {"grid by blocks in a 2.2 stream", e_bgrd_old, NULL, CNERF_E_UNKNOWN_CHUNK,
     CNERF_E_UNKNOWN_CHUNK, 0, 0},
    {"grid by blocks of 0 cells", e_bgrd_g0, NULL, CNERF_E_LIMIT, CNERF_E_LIMIT, 0, 0},
    {"grid by blocks: more occupied blocks than blocks", e_bgrd_blocks, NULL, CNERF_E_LIMIT,
     CNERF_E_LIMIT, 0, 0},
    {"grid by blocks: fewer occupied blocks than its payload", e_bgrd_fewer, NULL, CNERF_OK,
     CNERF_E_PAYLOAD, 0, 0},
    {"grid by blocks: size disagrees with its payload", e_bgrd_size, NULL, CNERF_OK,
     CNERF_E_PAYLOAD, 0, 0},
    {"grid by blocks: block frequency 0", e_bgrd_fb0, NULL, CNERF_E_TABLE, CNERF_E_TABLE, 0, 0},
    {"grid by blocks: cell frequency 0", e_bgrd_f0, NULL, CNERF_E_TABLE, CNERF_E_TABLE, 0, 0},
    {"grid by blocks cut in its tables", e_bgrd_cut, NULL, CNERF_E_CHUNK, CNERF_E_CHUNK, 0, 0},
    {"grid by blocks: payload under 4 bytes", e_bgrd_short, NULL, CNERF_E_PAYLOAD,
     CNERF_E_PAYLOAD, 0, 0},
    {"grid by blocks and a grid", e_bgrd_twice, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER,
     0, 0},
    {"grid by blocks after a layer", e_bgrd_after_layer, NULL, CNERF_E_CHUNK_ORDER,
     CNERF_E_CHUNK_ORDER, 0, 0},
    {"level 1 declared and met", e_level_ok, NULL, CNERF_OK, CNERF_OK, 0, 0},
    {"a level this decoder does not know is accepted", e_level_unknown, NULL, CNERF_OK,
     CNERF_OK, 0, 0},
    {"level 0", e_level_zero, NULL, CNERF_E_HEADER, CNERF_E_HEADER, 0, 0},
    {"level chunk of 2 bytes", e_level_long, NULL, CNERF_E_CHUNK, CNERF_E_CHUNK, 0, 0},
    {"level chunk after a layer", e_level_late, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER,
     0, 0},
    {"two level chunks", e_level_twice, NULL, CNERF_E_CHUNK_ORDER, CNERF_E_CHUNK_ORDER, 0, 0},
    {"more samples than the level declared", e_level_exceeded, NULL, CNERF_E_LEVEL_EXCEEDED,
     CNERF_E_LEVEL_EXCEEDED, 0, 0},
};

const size_t neg_case_count = sizeof neg_cases / sizeof neg_cases[0];

int neg_build(size_t i, cn_buf *out)
{
    static chunks cs;
    if (i >= neg_case_count || !base.p || !set_base.p)
        return -1;
    const neg_case *t = &neg_cases[i];
    const cn_buf *b = t->set ? &set_base : &base;
    split(b->p, b->n, &cs);
    if (t->edit)
        t->edit(&cs);
    memset(out, 0, sizeof *out);
    join(&cs, out);
    if (t->raw)
        t->raw(out);
    return 0;
}
