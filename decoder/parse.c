/*
 * Container walk, header and layer parsing, workspace layout and latent decoding.
 * Every read is bounds-checked; limits are checked before any size is computed.
 */
#include "../common/cn_fixed.h"
#include "cn_internal.h"
#include "cn_kernels.h"

void cn_memzero(void *p, size_t n)
{
    /* volatile: keeps the compiler from turning this loop into a memset call,
     * which a -nostdlib link cannot satisfy. Only small structs are zeroed. */
    volatile uint8_t *q = (volatile uint8_t *)p;
    while (n--)
        *q++ = 0;
}

uint32_t cnerf_crc32(uint32_t crc, const uint8_t *p, size_t len)
{
    static const uint32_t tab[16] = {
        0x00000000u, 0x1DB71064u, 0x3B6E20C8u, 0x26D930ACu, 0x76DC4190u, 0x6B6B51F4u,
        0x4DB26158u, 0x5005713Cu, 0xEDB88320u, 0xF00F9344u, 0xD6D6A3E8u, 0xCB61B38Cu,
        0x9B64C2B0u, 0x86D3D2D4u, 0xA00AE278u, 0xBDBDF21Cu};
    crc = ~crc;
    while (len--) {
        crc ^= *p++;
        crc = (crc >> 4) ^ tab[crc & 15u];
        crc = (crc >> 4) ^ tab[crc & 15u];
    }
    return ~crc;
}

static void set_layer(cnerf_info *info, uint32_t *l, uint32_t net, uint32_t idx, uint32_t role,
                      uint32_t n_in, uint32_t n_out)
{
    cnerf_layer_info *L = &info->layer[*l];
    L->net = (uint8_t)net;
    L->index = (uint8_t)idx;
    L->role = (uint8_t)role;
    L->n_in = (uint16_t)n_in;
    L->n_out = (uint16_t)n_out;
    /* Bounded by the limits: n_in <= CNERF_MAX_LAYER_IN, n_out <= CNERF_MAX_WIDTH, so
     * n_params <= CNERF_MAX_LAYERS * CNERF_MAX_LAYER_PARAMS < 2^26. */
    info->n_params += n_in * n_out;
    info->n_biases += n_out;
    (*l)++;
}

cnerf_status cnerf_expand_topology(cnerf_info *info)
{
    if (!info)
        return CNERF_E_NULL;
    if (info->l_pos > CNERF_MAX_L_POS || info->l_dir > CNERF_MAX_L_DIR)
        return CNERF_E_LIMIT;
    if (info->n_nets < 1u || info->n_nets > CNERF_MAX_NETS)
        return CNERF_E_LIMIT;
    if (info->pe_flags & ~CNERF_PE_INCLUDE_INPUT)
        return CNERF_E_HEADER;
    const uint32_t inc = (info->pe_flags & CNERF_PE_INCLUDE_INPUT) ? 3u : 0u;
    const uint32_t in_pos = inc + 6u * info->l_pos;
    const uint32_t in_dir = inc + 6u * info->l_dir;
    if (in_pos == 0u)
        return CNERF_E_HEADER;
    info->in_pos = (uint16_t)in_pos;
    info->in_dir = (uint16_t)in_dir;
    info->n_params = 0;
    info->n_biases = 0;
    uint32_t l = 0;
    for (uint32_t n = 0; n < info->n_nets; n++) {
        cnerf_net_info *N = &info->net[n];
        if (N->depth < 1u || N->depth > CNERF_MAX_DEPTH || N->width < 1u ||
            N->width > CNERF_MAX_WIDTH || N->view_width > CNERF_MAX_VIEW_WIDTH)
            return CNERF_E_LIMIT;
        if (N->skip != CNERF_NO_SKIP && (uint32_t)N->skip + 1u >= N->depth)
            return CNERF_E_HEADER; /* the skip must feed a later trunk layer */
        const uint32_t W = N->width, V = N->view_width;
        /* Units per layer (UNIT chunk): 0 reads as the full width, never more. */
        for (uint32_t i = 0; i < CNERF_MAX_DEPTH; i++) {
            if (i >= N->depth) {
                N->units[i] = 0;
                continue;
            }
            if (N->units[i] > W)
                return CNERF_E_HEADER;
            if (N->units[i] == 0u)
                N->units[i] = (uint16_t)W;
        }
        if (N->view_units > V)
            return CNERF_E_HEADER;
        if (N->view_units == 0u)
            N->view_units = (uint16_t)V;
        const uint32_t U = N->units[N->depth - 1u], VU = N->view_units;
        N->first_layer = (uint8_t)l;
        for (uint32_t i = 0; i < N->depth; i++) {
            uint32_t n_in = i ? N->units[i - 1u] : in_pos;
            if (N->skip != CNERF_NO_SKIP && i == (uint32_t)N->skip + 1u)
                n_in += in_pos;
            set_layer(info, &l, n, i, CNERF_ROLE_TRUNK, n_in, N->units[i]);
        }
        uint32_t i = N->depth;
        if (V) {
            set_layer(info, &l, n, i++, CNERF_ROLE_SIGMA, U, 1u);
            set_layer(info, &l, n, i++, CNERF_ROLE_FEATURE, U, W);
            set_layer(info, &l, n, i++, CNERF_ROLE_VIEW, W + in_dir, VU);
            set_layer(info, &l, n, i++, CNERF_ROLE_RGB, VU, 3u);
        } else {
            set_layer(info, &l, n, i++, CNERF_ROLE_OUTPUT, U, 4u);
        }
        N->n_layers = (uint8_t)(l - N->first_layer);
    }
    info->n_layers = l;
    return CNERF_OK;
}

/* A HEAD's render parameters: the fields before the topology (and n_nets). */
typedef struct head_render {
    uint8_t coord, background[3], n_nets;
    int32_t near_q16, far_q16, aabb_q16[6];
    uint16_t n_coarse, n_fine;
} head_render;

static void read_render(cn_reader *r, head_render *h, uint8_t topo[3])
{
    h->coord = (uint8_t)cn_rd_u8(r);
    for (int i = 0; i < 3; i++)
        topo[i] = (uint8_t)cn_rd_u8(r); /* l_pos, l_dir, pe_flags */
    h->near_q16 = cn_rd_i32(r);
    h->far_q16 = cn_rd_i32(r);
    for (int i = 0; i < 6; i++)
        h->aabb_q16[i] = cn_rd_i32(r);
    for (int i = 0; i < 3; i++)
        h->background[i] = (uint8_t)cn_rd_u8(r);
    h->n_coarse = (uint16_t)cn_rd_u16(r);
    h->n_fine = (uint16_t)cn_rd_u16(r);
    h->n_nets = (uint8_t)cn_rd_u8(r);
}

/* The rules on the render parameters, in the order the errors are reported. */
static cnerf_status check_render(const head_render *h, uint16_t minor)
{
    if (h->coord > CNERF_COORD_CONTRACT ||
        (h->coord == CNERF_COORD_CONTRACT && minor < CNERF_VERSION_MINOR_CONTRACT))
        return CNERF_E_HEADER;
    if (h->n_coarse < 1u || h->n_coarse > CNERF_MAX_SAMPLES || h->n_fine > CNERF_MAX_SAMPLES)
        return CNERF_E_LIMIT;
    if (h->n_nets != (h->n_fine ? 2u : 1u))
        return CNERF_E_HEADER;
    if (h->near_q16 < 0 || h->far_q16 <= h->near_q16)
        return CNERF_E_HEADER;
    if (h->coord == CNERF_COORD_NDC && (h->near_q16 != 0 || h->far_q16 != CNERF_Q16_ONE))
        return CNERF_E_HEADER;
    for (int i = 0; i < 3; i++)
        if (h->aabb_q16[i] >= h->aabb_q16[i + 3])
            return CNERF_E_HEADER;
    /* contracted scenes: the bounds are a cube whose inner half (a quarter of the width)
     * is at least 2^-14 wide, so that the contraction's ratio has 31 bits to work with */
    if (h->coord == CNERF_COORD_CONTRACT)
        for (int i = 0; i < 3; i++) {
            const int64_t w = (int64_t)h->aabb_q16[i + 3] - h->aabb_q16[i];
            if (w != (int64_t)h->aabb_q16[3] - h->aabb_q16[0] || w < 16)
                return CNERF_E_HEADER;
        }
    return CNERF_OK;
}

static void set_render(cnerf_info *info, const head_render *h)
{
    info->coord = h->coord;
    info->near_q16 = h->near_q16;
    info->far_q16 = h->far_q16;
    for (int i = 0; i < 6; i++)
        info->aabb_q16[i] = h->aabb_q16[i];
    for (int i = 0; i < 3; i++)
        info->background[i] = h->background[i];
    info->n_coarse = h->n_coarse;
    info->n_fine = h->n_fine;
    info->n_nets = h->n_nets;
}

cnerf_status cn_parse_head(const uint8_t *p, uint32_t clen, cnerf_info *info)
{
    cn_reader rd;
    cn_reader *r = &rd;
    cn_rd_init(r, p, clen);
    head_render h;
    uint8_t topo[3];
    read_render(r, &h, topo);
    set_render(info, &h);
    info->l_pos = topo[0];
    info->l_dir = topo[1];
    info->pe_flags = topo[2];
    if (r->err)
        return CNERF_E_CHUNK;
    if (info->n_nets < 1u || info->n_nets > CNERF_MAX_NETS)
        return CNERF_E_LIMIT;
    if (clen != CNERF_HEAD_FIXED_BYTES + CNERF_HEAD_NET_BYTES * (uint32_t)info->n_nets)
        return CNERF_E_CHUNK;
    for (uint32_t n = 0; n < info->n_nets; n++) {
        cnerf_net_info *N = &info->net[n];
        N->depth = (uint8_t)cn_rd_u8(r);
        N->width = (uint16_t)cn_rd_u16(r);
        N->skip = (uint8_t)cn_rd_u8(r);
        N->view_width = (uint16_t)cn_rd_u16(r);
    }
    if (r->err)
        return CNERF_E_CHUNK;
    const cnerf_status st = check_render(&h, info->version_minor);
    return st != CNERF_OK ? st : cnerf_expand_topology(info);
}

/* A later scene's HEAD (payload p, clen bytes) against the first one's (p0, len0): the same
 * length and topology bytes (CNERF_E_HEADER otherwise), and valid render parameters, which
 * go into info when `record`. */
static cnerf_status parse_scene_head(const uint8_t *p, uint32_t clen, const uint8_t *p0,
                                     uint32_t len0, cnerf_info *info, int record)
{
    cn_reader r;
    cn_rd_init(&r, p, clen);
    head_render h;
    uint8_t topo[3];
    read_render(&r, &h, topo);
    if (r.err)
        return CNERF_E_CHUNK;
    if (h.n_nets < 1u || h.n_nets > CNERF_MAX_NETS)
        return CNERF_E_LIMIT;
    if (clen != CNERF_HEAD_FIXED_BYTES + CNERF_HEAD_NET_BYTES * (uint32_t)h.n_nets)
        return CNERF_E_CHUNK;
    if (clen != len0)
        return CNERF_E_HEADER; /* another network count: another topology */
    for (uint32_t i = 1; i < clen; i++)
        if ((i < 4u || i >= CNERF_HEAD_FIXED_BYTES - 1u) && p[i] != p0[i])
            return CNERF_E_HEADER; /* l_pos, l_dir, pe_flags, n_nets and the networks */
    const cnerf_status st = check_render(&h, info->version_minor);
    if (st == CNERF_OK && record)
        set_render(info, &h);
    return st;
}

static int exp_ok(int32_t e) { return e >= CNERF_EXP_MIN && e <= CNERF_EXP_MAX; }

/* Where a coded matrix (latents or shifts) lies in its chunk. */
typedef struct coded_at {
    uint8_t prec, order;
    uint32_t table_bytes; /* the range, and prec, order and the table when coded */
    uint32_t table_offset, payload_offset, payload_bytes;
} coded_at;

/* The rest of a chunk [off, off + clen) after a coded matrix's range lo..hi, which the
 * reader r has just read: nothing for a constant matrix, else prec, order, the table and
 * the rANS payload (at least 4 bytes). */
static cnerf_status parse_coded(cn_reader *r, const uint8_t *buf, uint32_t off, uint32_t clen,
                                int32_t lo, int32_t hi, coded_at *c)
{
    c->prec = c->order = 0;
    c->table_bytes = 4u;
    if (lo == hi) {
        /* A constant matrix codes nothing. */
        c->table_offset = c->payload_offset = off + clen;
        c->payload_bytes = 0;
        return cn_rd_left(r) != 0u ? CNERF_E_CHUNK : CNERF_OK;
    }
    uint32_t prec = cn_rd_u8(r), k = cn_rd_u8(r);
    if (r->err)
        return CNERF_E_TABLE;
    if (prec < 1u || prec > CNERF_MAX_PREC || k > CNERF_MAX_EG_ORDER)
        return CNERF_E_TABLE;
    c->prec = (uint8_t)prec;
    c->order = (uint8_t)k;
    c->table_offset = off + (uint32_t)(r->p - (buf + off));
    cn_bits b;
    cn_bits_init(&b, r->p, cn_rd_left(r));
    /* hi - lo + 1 <= 65535 by the range check. */
    cnerf_status st = cn_table_read(&b, (uint32_t)(hi - lo) + 1u, prec, k, (uint32_t *)0);
    if (st != CNERF_OK)
        return st;
    uint32_t tbytes = (uint32_t)cn_bits_used(&b, r->p);
    c->table_bytes = 6u + tbytes;
    r->p += tbytes;
    c->payload_offset = off + (uint32_t)(r->p - (buf + off));
    c->payload_bytes = (uint32_t)cn_rd_left(r);
    return c->payload_bytes < 4u ? CNERF_E_PAYLOAD : CNERF_OK;
}

/* Parses one LAYR payload [p, p+clen) at absolute offset `off` of the stream. */
static cnerf_status parse_layer(const uint8_t *buf, uint32_t off, uint32_t clen,
                                cnerf_layer_info *L)
{
    cn_reader r;
    cn_rd_init(&r, buf + off, clen);
    uint32_t net = cn_rd_u8(&r), index = cn_rd_u8(&r);
    uint32_t n_in = cn_rd_u16(&r), n_out = cn_rd_u16(&r);
    if (r.err)
        return CNERF_E_CHUNK;
    if (net != L->net || index != L->index)
        return CNERF_E_CHUNK_ORDER;
    if (n_in != L->n_in || n_out != L->n_out)
        return CNERF_E_LAYER;
    const int32_t f_in = cn_rd_i8(&r);
    int32_t a_m = cn_rd_i24(&r), a_e = cn_rd_i8(&r);
    int32_t b_m = cn_rd_i24(&r), b_e = cn_rd_i8(&r);
    uint32_t bias_bits = cn_rd_u8(&r);
    int32_t bias_e = cn_rd_i8(&r);
    if (r.err)
        return CNERF_E_CHUNK;
    if (a_m < -CNERF_M24_ABS_MAX || b_m < -CNERF_M24_ABS_MAX || !exp_ok(a_e) || !exp_ok(b_e) ||
        !exp_ok(bias_e) || bias_bits > CNERF_MAX_BIAS_BITS || (bias_bits == 0u && bias_e != 0) ||
        f_in < CNERF_F_MIN || f_in > CNERF_F_MAX)
        return CNERF_E_FORMAT;
    L->f_in = (int8_t)f_in;
    L->a_m = a_m;
    L->a_e = (int8_t)a_e;
    L->b_m = b_m;
    L->b_e = (int8_t)b_e;
    L->bias_bits = (uint8_t)bias_bits;
    L->bias_e = (int8_t)bias_e;
    /* n_out * bias_bits <= 1024 * 24: no overflow. */
    const uint32_t bias_packed = (n_out * bias_bits + 7u) >> 3;
    if (cn_rd_left(&r) < bias_packed)
        return CNERF_E_CHUNK;
    L->bias_offset = off + (uint32_t)(r.p - (buf + off));
    r.p += bias_packed;
    int32_t kmin = cn_rd_i16(&r), kmax = cn_rd_i16(&r);
    if (r.err)
        return CNERF_E_CHUNK;
    if (kmin < -CNERF_MAX_ABS_K || kmax < -CNERF_MAX_ABS_K || kmin > kmax)
        return CNERF_E_RANGE;
    L->kmin = kmin;
    L->kmax = kmax;
    L->header_bytes = 7u;
    L->affine_bytes = 8u;
    L->bias_bytes = 2u + bias_packed;
    coded_at c;
    const cnerf_status st = parse_coded(&r, buf, off, clen, kmin, kmax, &c);
    L->prec = c.prec;
    L->eg_order = c.order;
    L->table_bytes = c.table_bytes;
    L->table_offset = c.table_offset;
    L->payload_offset = c.payload_offset;
    L->payload_bytes = c.payload_bytes;
    return st;
}

/* Parses one SHFT payload [off, off + clen) for layer L into S. */
static cnerf_status parse_shift(const uint8_t *buf, uint32_t off, uint32_t clen,
                                const cnerf_layer_info *L, cnerf_shift_info *S)
{
    cn_reader r;
    cn_rd_init(&r, buf + off, clen);
    const uint32_t net = cn_rd_u8(&r), index = cn_rd_u8(&r);
    const uint32_t n_in = cn_rd_u16(&r), n_out = cn_rd_u16(&r);
    const int32_t g_m = cn_rd_i24(&r), g_e = cn_rd_i8(&r);
    const int32_t smin = cn_rd_i16(&r), smax = cn_rd_i16(&r);
    if (r.err)
        return CNERF_E_CHUNK;
    if (net != L->net || index != L->index)
        return CNERF_E_CHUNK_ORDER;
    if (n_in != L->n_in || n_out != L->n_out)
        return CNERF_E_LAYER;
    if (g_m < -CNERF_M24_ABS_MAX || !exp_ok(g_e))
        return CNERF_E_FORMAT;
    if (smin < -CNERF_MAX_ABS_K || smax < -CNERF_MAX_ABS_K || smin > smax)
        return CNERF_E_RANGE;
    S->g_m = g_m;
    S->g_e = (int8_t)g_e;
    S->smin = smin;
    S->smax = smax;
    coded_at c;
    const cnerf_status st = parse_coded(&r, buf, off, clen, smin, smax, &c);
    S->prec = c.prec;
    S->eg_order = c.order;
    S->table_offset = c.table_offset;
    S->payload_offset = c.payload_offset;
    S->payload_bytes = c.payload_bytes;
    return st;
}

/* 1 when the layer's kernel has a shift term (not every shift 0). */
static int has_shift(const cnerf_shift_info *S) { return S->smin != 0 || S->smax != 0; }

/* A GRID chunk's fields (cnerf_info's grid_* fields). */
typedef struct grid_fields {
    uint8_t g, prec;
    uint16_t f1[CNERF_GRID_CONTEXTS];
    uint32_t payload_offset, payload_bytes;
} grid_fields;

/* Parses a GRID payload [off, off + clen) of the stream into gf. */
static cnerf_status parse_grid(const uint8_t *buf, uint32_t off, uint32_t clen, grid_fields *gf)
{
    cn_reader r;
    cn_rd_init(&r, buf + off, clen);
    const uint32_t g = cn_rd_u8(&r), prec = cn_rd_u8(&r);
    uint32_t f1[CNERF_GRID_CONTEXTS];
    for (unsigned c = 0; c < CNERF_GRID_CONTEXTS; c++)
        f1[c] = cn_rd_u16(&r);
    if (r.err)
        return CNERF_E_CHUNK;
    if (g < 1u || g > CNERF_MAX_GRID)
        return CNERF_E_LIMIT;
    if (prec < 1u || prec > CNERF_MAX_PREC)
        return CNERF_E_TABLE;
    for (unsigned c = 0; c < CNERF_GRID_CONTEXTS; c++) {
        if (f1[c] < 1u || f1[c] >= ((uint32_t)1u << prec))
            return CNERF_E_TABLE; /* both symbols need a frequency of at least 1 */
        gf->f1[c] = (uint16_t)f1[c];
    }
    gf->g = (uint8_t)g;
    gf->prec = (uint8_t)prec;
    gf->payload_offset = off + CNERF_GRID_FIXED_BYTES;
    gf->payload_bytes = clen - CNERF_GRID_FIXED_BYTES;
    return gf->payload_bytes < 4u ? CNERF_E_PAYLOAD : CNERF_OK;
}

/* Parses a UNIT payload: per network, the units of each trunk layer, then of the view
 * layer when there is one (u16 each, 1..width); re-expands the topology with them. */
static cnerf_status parse_units(const uint8_t *p, uint32_t clen, cnerf_info *info)
{
    cn_reader r;
    cn_rd_init(&r, p, clen);
    uint32_t need = 0;
    for (uint32_t n = 0; n < info->n_nets; n++)
        need += 2u * ((uint32_t)info->net[n].depth + (info->net[n].view_width ? 1u : 0u));
    if (clen != need)
        return CNERF_E_CHUNK;
    for (uint32_t n = 0; n < info->n_nets; n++) {
        cnerf_net_info *N = &info->net[n];
        for (uint32_t i = 0; i < N->depth; i++)
            N->units[i] = (uint16_t)cn_rd_u16(&r);
        if (N->view_width)
            N->view_units = (uint16_t)cn_rd_u16(&r);
        for (uint32_t i = 0; i < N->depth; i++)
            if (N->units[i] == 0u)
                return CNERF_E_HEADER; /* a layer keeps at least one unit */
        if (N->view_width && N->view_units == 0u)
            return CNERF_E_HEADER;
    }
    return cnerf_expand_topology(info); /* checks units <= width */
}

static int tag_ok(uint32_t tag)
{
    for (int i = 0; i < 4; i++) {
        uint32_t c = (tag >> (8 * i)) & 0xFFu;
        if (!((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z')))
            return 0;
    }
    return 1;
}

cnerf_status cn_parse(const uint8_t *buf, size_t len, uint32_t want, cnerf_info *info)
{
    cn_memzero(info, sizeof *info);
    static const uint8_t magic[4] = {CNERF_MAGIC_0, CNERF_MAGIC_1, CNERF_MAGIC_2, CNERF_MAGIC_3};
    for (size_t i = 0; i < 4u; i++) {
        if (i >= len)
            return CNERF_E_TRUNCATED; /* a prefix of the magic */
        if (buf[i] != magic[i])
            return CNERF_E_MAGIC;
    }
    if ((len >> 16) >> 16) /* offsets are 32-bit; written so 32-bit size_t warns not */
        return CNERF_E_LIMIT;
    cn_reader r;
    cn_rd_init(&r, buf, len);
    r.p += 4;
    info->version_major = (uint16_t)cn_rd_u16(&r);
    info->version_minor = (uint16_t)cn_rd_u16(&r);
    if (r.err)
        return CNERF_E_TRUNCATED;
    if (info->version_major != CNERF_VERSION_MAJOR)
        return CNERF_E_VERSION;
    info->signature_bytes = CNERF_SIGNATURE_BYTES;
    info->n_scenes = 1;
    /* The walk: the first HEAD, then SCNS (several scenes), UNIT, one SHFT per layer; then
     * per scene its HEAD (not for scene 0), GRID and layers; DONE. `scene` is the scene whose
     * chunks are being read; only the wanted one's go into info, the others are checked the
     * same way into scratch fields. */
    int seen_head = 0, grid_seen = 0, set = 0; /* set: a SCNS chunk was read */
    uint32_t next_layer = 0, next_shift = 0, scene = 0, head0_off = 0, head0_len = 0;
    for (;;) {
        const uint32_t off = (uint32_t)(r.p - buf);
        if (cn_rd_left(&r) < 8u)
            return CNERF_E_TRUNCATED;
        const uint32_t tag = cn_rd_u32(&r);
        const uint32_t clen = cn_rd_u32(&r);
        if (cn_rd_left(&r) < 4u || cn_rd_left(&r) - 4u < clen)
            return CNERF_E_TRUNCATED;
        const uint32_t poff = off + 8u;
        uint32_t crc = cnerf_crc32(0, buf + off, 4u);
        crc = cnerf_crc32(crc, buf + poff, clen);
        r.p += clen;
        const uint32_t stored = cn_rd_u32(&r);
#ifndef FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION
        if (stored != crc)
            return CNERF_E_CRC;
#else
        (void)stored; /* fuzz builds: let mutations reach the chunk parsers */
#endif
        if (!tag_ok(tag))
            return CNERF_E_CHUNK;
        const int critical = (tag & 0xFFu) >= 'A' && (tag & 0xFFu) <= 'Z';
        const uint32_t cbytes = clen + CNERF_CHUNK_OVERHEAD;
        const int record = scene == want;
        const int shared_done = !set || next_shift == info->n_layers;
        cnerf_status st;
        if (!seen_head && tag != CNERF_TAG_HEAD)
            return CNERF_E_CHUNK_ORDER;
        if (tag == CNERF_TAG_HEAD && !seen_head) {
            if ((st = cn_parse_head(buf + poff, clen, info)) != CNERF_OK)
                return st;
            seen_head = 1;
            head0_off = poff;
            head0_len = clen;
            if (record) {
                info->head_bytes = cbytes;
                info->scene_bytes += cbytes;
            }
        } else if (tag == CNERF_TAG_HEAD) {
            /* The next scene: after every layer of this one, within the scene count. */
            if (scene + 1u >= info->n_scenes || next_layer != info->n_layers)
                return CNERF_E_CHUNK_ORDER;
            scene++;
            next_layer = 0;
            grid_seen = 0;
            if ((st = parse_scene_head(buf + poff, clen, buf + head0_off, head0_len, info,
                                       scene == want)) != CNERF_OK)
                return st;
            if (scene == want) {
                info->head_bytes = cbytes;
                info->scene_bytes += cbytes;
            }
        } else if (tag == CNERF_TAG_SCNS) {
            /* Right after the first HEAD (ancillary chunks aside), at most once. */
            if (set || info->unit_bytes || grid_seen || next_layer > 0u)
                return CNERF_E_CHUNK_ORDER;
            if (clen != 1u)
                return CNERF_E_CHUNK;
            const uint32_t n = buf[poff];
            if (n < 1u || n > CNERF_MAX_SCENES)
                return CNERF_E_LIMIT;
            info->n_scenes = (uint8_t)n;
            set = 1;
            info->shared_bytes += cbytes;
        } else if (tag == CNERF_TAG_SHFT) {
            /* One per layer, in order, after SCNS and UNIT, before scene 0's grid and layers. */
            if (!set || scene > 0u || grid_seen || next_layer > 0u ||
                next_shift >= info->n_layers)
                return CNERF_E_CHUNK_ORDER;
            cnerf_shift_info *S = &info->shift[next_shift];
            if ((st = parse_shift(buf, poff, clen, &info->layer[next_shift], S)) != CNERF_OK)
                return st;
            S->chunk_offset = off;
            S->chunk_bytes = cbytes;
            if (has_shift(S))
                info->n_shift_params +=
                    (uint32_t)info->layer[next_shift].n_in * info->layer[next_shift].n_out;
            info->shared_bytes += cbytes;
            next_shift++;
        } else if (tag == CNERF_TAG_LAYR) {
            if (next_layer >= info->n_layers || !shared_done)
                return CNERF_E_CHUNK_ORDER;
            cnerf_layer_info other, *L = &info->layer[next_layer];
            if (!record) { /* another scene's layer: checked against the same shape */
                cn_memzero(&other, sizeof other); /* field by field: no memcpy here */
                other.net = L->net;
                other.index = L->index;
                other.n_in = L->n_in;
                other.n_out = L->n_out;
                L = &other;
            }
            if ((st = parse_layer(buf, poff, clen, L)) != CNERF_OK)
                return st;
            L->chunk_offset = off;
            L->chunk_bytes = cbytes;
            if (record)
                info->scene_bytes += cbytes;
            next_layer++;
        } else if (tag == CNERF_TAG_UNIT) {
            /* At most one, before the shifts, the grid and the first layer. */
            if (info->unit_bytes || grid_seen || next_layer > 0u || next_shift > 0u ||
                scene > 0u)
                return CNERF_E_CHUNK_ORDER;
            if ((st = parse_units(buf + poff, clen, info)) != CNERF_OK)
                return st;
            info->unit_bytes = cbytes;
        } else if (tag == CNERF_TAG_GRID) {
            /* At most one per scene, before its first layer (and after the shifts). */
            if (grid_seen || next_layer > 0u || !shared_done)
                return CNERF_E_CHUNK_ORDER;
            grid_fields gf;
            if ((st = parse_grid(buf, poff, clen, &gf)) != CNERF_OK)
                return st;
            grid_seen = 1;
            if (record) {
                info->grid_g = gf.g;
                info->grid_prec = gf.prec;
                for (unsigned c = 0; c < CNERF_GRID_CONTEXTS; c++)
                    info->grid_f1[c] = gf.f1[c];
                info->grid_payload_offset = gf.payload_offset;
                info->grid_payload_bytes = gf.payload_bytes;
                info->grid_bytes = cbytes;
                info->scene_bytes += cbytes;
            }
        } else if (tag == CNERF_TAG_DONE) {
            if (clen != 0u)
                return CNERF_E_CHUNK;
            if (next_layer != info->n_layers || scene + 1u != info->n_scenes || !shared_done)
                return CNERF_E_CHUNK_ORDER;
            info->done_bytes = cbytes;
            info->file_bytes = off + cbytes;
            if (cn_rd_left(&r))
                return CNERF_E_TRAILING;
            if (want >= info->n_scenes)
                return CNERF_E_ARG;
            info->scene = (uint8_t)want;
            return CNERF_OK;
        } else if (critical) {
            return CNERF_E_UNKNOWN_CHUNK;
        } else {
            info->ancillary_bytes += cbytes;
            if (tag == CNERF_TAG_META && info->meta_offset == 0u) {
                info->meta_offset = poff;
                info->meta_len = clen;
            }
        }
    }
}

cnerf_status cnerf_peek_scene(const uint8_t *buf, size_t len, uint32_t scene, cnerf_info *info)
{
    if (!info || (!buf && len))
        return CNERF_E_NULL;
    return cn_parse(buf ? buf : (const uint8_t *)"", len, scene, info);
}

cnerf_status cnerf_peek(const uint8_t *buf, size_t len, cnerf_info *info)
{
    return cnerf_peek_scene(buf, len, 0, info);
}

static size_t align8(size_t n) { return (n + 7u) & ~(size_t)7u; }

/* Alphabet size of a coded layer, 0 for a constant one. */
static uint32_t alphabet(const cnerf_layer_info *L)
{
    return L->kmin < L->kmax ? (uint32_t)(L->kmax - L->kmin) + 1u : 0u;
}

/* Bytes of the occupancy bitmap of g^3 cells (g <= CNERF_MAX_GRID: at most 2^18). */
static size_t grid_bitmap_bytes(uint32_t g) { return ((size_t)g * g * g + 7u) >> 3; }

/* Inputs of a layer padded to whole pairs (the kernels take two at a time). */
static uint32_t in_pad(const cnerf_layer_info *L) { return ((uint32_t)L->n_in + 1u) & ~1u; }

size_t cnerf_workspace_size(const cnerf_info *info)
{
    if (!info || info->n_layers > CNERF_MAX_LAYERS)
        return 0;
    /* Every term is bounded by the limits (see CNERF_WORKSPACE_BOUND), and the total is
     * below 2^29 bytes, so size_t arithmetic cannot overflow even where it is 32 bits. */
    size_t total = 0, scratch = 0;
    for (uint32_t l = 0; l < info->n_layers; l++) {
        const cnerf_layer_info *L = &info->layer[l];
        const cnerf_shift_info *S = &info->shift[l];
        total += align8((size_t)in_pad(L) * L->n_out * 2u); /* packed int16 latents */
        if (has_shift(S))
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
        total += align8(grid_bitmap_bytes(info->grid_g));
    return total + align8(scratch);
}

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

/* Decodes a coded matrix row-major into lat, rows of in_pad int16 with a zero in the pad
 * column. */
static cnerf_status decode_matrix(const uint8_t *buf, const coded *C, int16_t *lat, uint32_t *cum)
{
    const uint32_t n_in = C->n_in, n_out = C->n_out, pad = (n_in + 1u) & ~1u;
    const uint32_t count = n_in * n_out;
    if (C->lo == C->hi) {
        for (uint32_t i = 0; i < count; i++)
            lat[i] = (int16_t)C->lo;
    } else {
        const uint32_t n = (uint32_t)(C->hi - C->lo) + 1u;
        cn_bits b;
        cn_bits_init(&b, buf + C->table_offset, C->payload_offset - C->table_offset);
        cnerf_status st = cn_table_read(&b, n, C->prec, C->order, cum);
        if (st == CNERF_OK)
            st = cn_rans_decode(buf + C->payload_offset, C->payload_bytes, cum, n, C->prec,
                                C->lo, lat, 2u, count);
        if (st != CNERF_OK)
            return st;
    }
    if (pad != n_in) {
        /* spread the rows to their padded stride, last first (each moves up) */
        for (uint32_t o = n_out; o-- > 0u;) {
            lat[(size_t)o * pad + n_in] = 0;
            for (uint32_t i = n_in; i-- > 0u;)
                lat[(size_t)o * pad + i] = lat[(size_t)o * n_in + i];
        }
    }
    return CNERF_OK;
}

/* The latents' packed layout (cnerf_decoder.latent): the index of k[j][i] of stored row j
 * among n_live live rows of `pairs` input pairs. */
static size_t packed_index(uint32_t j, uint32_t i, uint32_t live, uint32_t pairs)
{
    const uint32_t b = j >> 2, q = j & 3u;
    if ((b + 1u) * 4u > live) /* the last one to three rows: row after row */
        return (size_t)b * 8u * pairs + (size_t)q * 2u * pairs + i;
    return (size_t)b * 8u * pairs + (size_t)(i >> 1) * 8u + 2u * q + (i & 1u);
}

/* Sum |v| of row o of a padded matrix (<= 1124 * 32767 < 2^26). */
static uint32_t row_abs_sum(const int16_t *m, uint32_t o, uint32_t pad)
{
    const int16_t *row = m + (size_t)o * pad;
    uint32_t sum = 0;
    for (uint32_t i = 0; i < pad; i++) {
        const int32_t k = row[i];
        sum += (uint32_t)(k < 0 ? -k : k);
    }
    return sum;
}

/* Orders the layer's rows: live ones (a non-zero latent, or a non-zero shift when `sh` is
 * not NULL) first, in increasing output order; rows[] gets each stored row's output index,
 * the all-zero rows last. Puts the largest sum |k| of a row into *maxsum and the largest
 * sum |s| into *maxshift. Returns the live rows. */
static uint16_t order_rows(const cnerf_layer_info *L, const int16_t *lat, const int16_t *sh,
                           uint16_t *rows, uint32_t *maxsum, uint32_t *maxshift)
{
    const uint32_t pad = in_pad(L), n_out = L->n_out;
    uint32_t live = 0, dead = n_out;
    *maxsum = *maxshift = 0;
    for (uint32_t o = 0; o < n_out; o++) {
        const uint32_t sum = row_abs_sum(lat, o, pad), ss = sh ? row_abs_sum(sh, o, pad) : 0u;
        *maxsum = sum > *maxsum ? sum : *maxsum;
        *maxshift = ss > *maxshift ? ss : *maxshift;
        if (sum || ss)
            rows[live++] = (uint16_t)o;
        else
            rows[--dead] = (uint16_t)o; /* fills from the end, in decreasing order */
    }
    return (uint16_t)live;
}

/* Packs the live rows of lat (in the order of rows[]) into blocks of four, using `tmp`
 * (4 padded rows), and zeroes the rest. A block's rows come from row slots at or after its
 * own (a live row's output index is at least its rank), so writing block b overwrites only
 * slots that were copied to tmp, belong to earlier blocks or hold zeros. */
static void pack_rows(const cnerf_layer_info *L, int16_t *lat, const uint16_t *rows,
                      uint32_t live, int16_t *tmp)
{
    const uint32_t pad = in_pad(L), n_out = L->n_out;
    for (uint32_t b = 0; 4u * b < live; b++) {
        const uint32_t rb = live - 4u * b < 4u ? live - 4u * b : 4u;
        int16_t *blk = lat + (size_t)b * 4u * pad;
        for (uint32_t q = 0; q < rb; q++)
            for (uint32_t i = 0; i < pad; i++)
                tmp[(size_t)q * pad + i] = lat[(size_t)rows[4u * b + q] * pad + i];
        if (rb < 4u) { /* the last rows, row after row: as they are (packed_index) */
            for (uint32_t i = 0; i < rb * pad; i++)
                blk[i] = tmp[i];
            continue;
        }
        for (uint32_t i = 0; i < pad; i++) /* pair by pair: k[q][i] at (i / 2) 8 + 2 q + i % 2 */
            for (uint32_t q = 0; q < 4u; q++)
                blk[(i >> 1) * 8u + 2u * q + (i & 1u)] = tmp[(size_t)q * pad + i];
    }
    for (size_t i = (size_t)live * pad; i < (size_t)n_out * pad; i++)
        lat[i] = 0;
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

/* Reorders layer l's input columns from its producer's outputs into the producer's stored
 * row order: column off + j takes column off + rows_p[j]. tmp holds one row. */
static void order_columns(const cnerf_decoder *dec, uint32_t l, int16_t *lat, int16_t *tmp)
{
    uint32_t off;
    const int p = producer(&dec->info, l, &off);
    if (p < 0)
        return;
    const cnerf_layer_info *L = &dec->info.layer[l];
    const uint32_t pad = in_pad(L), U = dec->info.layer[p].n_out;
    const uint16_t *rows = dec->rows[p];
    for (uint32_t o = 0; o < L->n_out; o++) {
        int16_t *row = lat + (size_t)o * pad;
        for (uint32_t j = 0; j < U; j++)
            tmp[j] = row[off + rows[j]];
        for (uint32_t j = 0; j < U; j++)
            row[off + j] = tmp[j];
    }
}

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
    const cnerf_layer_info *L = &dec->info.layer[l];
    dec->wide[l] = maxsum > 65535u;
    dec->shift_wide[l] = maxshift > 65535u; /* the same bound for the sums s x_q */
    const int n = -((int)L->a_e + 16 - (int)L->f_in);
    const uint64_t am = (uint64_t)(L->a_m < 0 ? -L->a_m : L->a_m); /* < 2^23 */
    const uint64_t bound = ((uint64_t)maxsum << 15) * am;           /* < 2^16 2^15 2^23 */
    dec->a_shift[l] = 0;
    /* A layer with a shift adds its term before the offset and bias: the general path. */
    if (!dec->wide[l] && !dec->shift[l] && n >= 1 && n <= 62 && (bound >> 30) >> n == 0u)
        dec->a_shift[l] = (uint8_t)n;
    /* b sum x_q: |sum x_q| <= 2^15 n_in */
    const int nb = -((int)L->b_e + 16 - (int)L->f_in);
    const uint64_t bm = (uint64_t)(L->b_m < 0 ? -L->b_m : L->b_m);
    const uint64_t bbound = ((uint64_t)L->n_in << 15) * bm; /* < 2^11 2^15 2^23 */
    dec->b_shift[l] = 0;
    if (nb >= 1 && nb <= 62 && (bbound >> 30) >> nb == 0u)
        dec->b_shift[l] = (uint8_t)nb;
}

cnerf_status cnerf_open_scene(cnerf_decoder *dec, const uint8_t *buf, size_t len,
                              uint32_t scene, void *ws, size_t ws_size)
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
    cnerf_status st = cn_parse(buf, len, scene, &dec->info);
    if (st == CNERF_OK && ws_size < cnerf_workspace_size(&dec->info))
        st = CNERF_E_WS_SMALL;
    uint8_t *w = (uint8_t *)ws;
    const cnerf_info *info = &dec->info;
    uint8_t *scratch = (uint8_t *)0;
    if (st == CNERF_OK) {
        /* Layout: per layer latents, biases and row order; the grid; open's scratch last. */
        for (uint32_t l = 0; l < info->n_layers; l++) {
            const cnerf_layer_info *L = &info->layer[l];
            dec->latent[l] = (const int16_t *)(void *)w;
            w += align8((size_t)in_pad(L) * L->n_out * 2u);
            if (has_shift(&info->shift[l])) {
                dec->shift[l] = (const int16_t *)(void *)w;
                w += align8((size_t)in_pad(L) * L->n_out * 2u);
            }
            dec->bias[l] = (const int32_t *)(void *)w;
            w += align8((size_t)L->n_out * 4u);
            dec->bias_q16[l] = (const int32_t *)(void *)w;
            w += align8((size_t)L->n_out * 4u);
            dec->rows[l] = (const uint16_t *)(void *)w;
            w += align8((size_t)L->n_out * 2u);
            dec->n_pairs[l] = (uint16_t)(in_pad(L) / 2u);
        }
        if (info->grid_g) {
            const size_t nb = grid_bitmap_bytes(info->grid_g);
            st = cn_grid_decode(buf + info->grid_payload_offset, info->grid_payload_bytes,
                                info->grid_g, info->grid_prec, info->grid_f1, w,
                                &dec->grid_occupied);
            dec->grid = w;
            w += align8(nb);
        }
        scratch = w;
    }
    for (uint32_t l = 0; st == CNERF_OK && l < info->n_layers; l++) {
        const cnerf_layer_info *L = &info->layer[l];
        int32_t *bias = (int32_t *)(uintptr_t)dec->bias[l];
        int16_t *lat = (int16_t *)(uintptr_t)dec->latent[l];
        uint16_t *rows = (uint16_t *)(uintptr_t)dec->rows[l];
        int16_t *sh = (int16_t *)(uintptr_t)dec->shift[l]; /* NULL: no shift */
        int16_t *tmp = (int16_t *)(void *)scratch;
        const coded ck = coded_latents(L), cs = coded_shifts(L, &info->shift[l]);
        st = read_biases(buf, L, bias);
        if (st == CNERF_OK)
            st = decode_matrix(buf, &ck, lat, (uint32_t *)(void *)scratch);
        if (st == CNERF_OK && sh)
            st = decode_matrix(buf, &cs, sh, (uint32_t *)(void *)scratch);
        if (st != CNERF_OK)
            break;
        order_columns(dec, l, lat, tmp);
        if (sh)
            order_columns(dec, l, sh, tmp);
        uint32_t maxsum, maxshift;
        const uint16_t live = order_rows(L, lat, sh, rows, &maxsum, &maxshift);
        dec->n_live[l] = live;
        pack_rows(L, lat, rows, live, tmp);
        if (sh)
            pack_rows(L, sh, rows, live, tmp);
        int32_t *bq = (int32_t *)(uintptr_t)dec->bias_q16[l];
        for (uint32_t j = 0; j < L->n_out; j++)
            bq[j] = L->bias_bits ? q16_bias(bias[rows[j]], L->bias_e) : 0;
        prove_layer(dec, l, maxsum, maxshift);
    }
    if (st == CNERF_OK) {
        const cn_dot_variant v = cn_dot_select();
        dec->dot = v.fn;
        dec->requant = v.requant;
        dec->finish = v.finish;
    }
    if (st != CNERF_OK)
        cn_memzero(dec, sizeof *dec);
    return st;
}

cnerf_status cnerf_open(cnerf_decoder *dec, const uint8_t *buf, size_t len, void *ws,
                        size_t ws_size)
{
    return cnerf_open_scene(dec, buf, len, 0, ws, ws_size);
}

/* Element (o, i) of layer l's packed matrix m (its latents or its shifts). */
static int32_t packed_at(const cnerf_decoder *dec, uint32_t l, const int16_t *m, uint32_t o,
                         uint32_t i)
{
    const cnerf_layer_info *L = &dec->info.layer[l];
    if (o >= L->n_out || i >= L->n_in || !m)
        return 0;
    /* Live rows are stored first, in increasing output order (order_rows): a search, since
     * this accessor is for tools and tests, not for rendering. */
    uint32_t j = 0;
    while (j < dec->n_live[l] && dec->rows[l][j] != o)
        j++;
    if (j == dec->n_live[l])
        return 0; /* an all-zero row */
    uint32_t off, c = i;
    const int p = producer(&dec->info, l, &off);
    if (p >= 0 && i >= off && i - off < dec->info.layer[p].n_out) {
        c = off; /* the column of input i: its producer's stored row */
        while (dec->rows[p][c - off] != i - off)
            c++;
    }
    return m[packed_index(j, c, dec->n_live[l], dec->n_pairs[l])];
}

int32_t cnerf_latent(const cnerf_decoder *dec, uint32_t l, uint32_t o, uint32_t i)
{
    return dec && l < dec->info.n_layers ? packed_at(dec, l, dec->latent[l], o, i) : 0;
}

int32_t cnerf_shift(const cnerf_decoder *dec, uint32_t l, uint32_t o, uint32_t i)
{
    return dec && l < dec->info.n_layers ? packed_at(dec, l, dec->shift[l], o, i) : 0;
}
