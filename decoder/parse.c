/*
 * Container walk, header and layer parsing, workspace layout and latent decoding.
 * Every read is bounds-checked; limits are checked before any size is computed.
 */
#include "cn_fixed.h"
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

cnerf_status cn_parse_head(const uint8_t *p, uint32_t clen, cnerf_info *info)
{
    cn_reader rd;
    cn_reader *r = &rd;
    cn_rd_init(r, p, clen);
    info->coord = (uint8_t)cn_rd_u8(r);
    info->l_pos = (uint8_t)cn_rd_u8(r);
    info->l_dir = (uint8_t)cn_rd_u8(r);
    info->pe_flags = (uint8_t)cn_rd_u8(r);
    info->near_q16 = cn_rd_i32(r);
    info->far_q16 = cn_rd_i32(r);
    for (int i = 0; i < 6; i++)
        info->aabb_q16[i] = cn_rd_i32(r);
    for (int i = 0; i < 3; i++)
        info->background[i] = (uint8_t)cn_rd_u8(r);
    info->n_coarse = (uint16_t)cn_rd_u16(r);
    info->n_fine = (uint16_t)cn_rd_u16(r);
    info->n_nets = (uint8_t)cn_rd_u8(r);
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
    if (info->coord > CNERF_COORD_NDC)
        return CNERF_E_HEADER;
    if (info->n_coarse < 1u || info->n_coarse > CNERF_MAX_SAMPLES ||
        info->n_fine > CNERF_MAX_SAMPLES)
        return CNERF_E_LIMIT;
    if (info->n_nets != (info->n_fine ? 2u : 1u))
        return CNERF_E_HEADER;
    if (info->near_q16 < 0 || info->far_q16 <= info->near_q16)
        return CNERF_E_HEADER;
    if (info->coord == CNERF_COORD_NDC &&
        (info->near_q16 != 0 || info->far_q16 != CNERF_Q16_ONE))
        return CNERF_E_HEADER;
    for (int i = 0; i < 3; i++)
        if (info->aabb_q16[i] >= info->aabb_q16[i + 3])
            return CNERF_E_HEADER;
    return cnerf_expand_topology(info);
}

static int exp_ok(int32_t e) { return e >= CNERF_EXP_MIN && e <= CNERF_EXP_MAX; }

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
    L->table_bytes = 4u;
    L->prec = 0;
    L->eg_order = 0;
    if (kmin == kmax) {
        /* A constant layer codes nothing. */
        if (cn_rd_left(&r) != 0u)
            return CNERF_E_CHUNK;
        L->table_offset = L->payload_offset = off + clen;
        L->payload_bytes = 0;
        return CNERF_OK;
    }
    uint32_t prec = cn_rd_u8(&r), k = cn_rd_u8(&r);
    if (r.err)
        return CNERF_E_TABLE;
    if (prec < 1u || prec > CNERF_MAX_PREC || k > CNERF_MAX_EG_ORDER)
        return CNERF_E_TABLE;
    L->prec = (uint8_t)prec;
    L->eg_order = (uint8_t)k;
    L->table_offset = off + (uint32_t)(r.p - (buf + off));
    cn_bits b;
    cn_bits_init(&b, r.p, cn_rd_left(&r));
    /* kmax - kmin + 1 <= 65535 by the range check. */
    cnerf_status st = cn_table_read(&b, (uint32_t)(kmax - kmin) + 1u, prec, k, (uint32_t *)0);
    if (st != CNERF_OK)
        return st;
    uint32_t tbytes = (uint32_t)cn_bits_used(&b, r.p);
    L->table_bytes = 6u + tbytes;
    r.p += tbytes;
    L->payload_offset = off + (uint32_t)(r.p - (buf + off));
    L->payload_bytes = (uint32_t)cn_rd_left(&r);
    if (L->payload_bytes < 4u)
        return CNERF_E_PAYLOAD;
    return CNERF_OK;
}

/* Parses a GRID payload [off, off + clen) of the stream into info. */
static cnerf_status parse_grid(const uint8_t *buf, uint32_t off, uint32_t clen, cnerf_info *info)
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
        info->grid_f1[c] = (uint16_t)f1[c];
    }
    info->grid_g = (uint8_t)g;
    info->grid_prec = (uint8_t)prec;
    info->grid_payload_offset = off + CNERF_GRID_FIXED_BYTES;
    info->grid_payload_bytes = clen - CNERF_GRID_FIXED_BYTES;
    return info->grid_payload_bytes < 4u ? CNERF_E_PAYLOAD : CNERF_OK;
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

cnerf_status cn_parse(const uint8_t *buf, size_t len, cnerf_info *info)
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
    int seen_head = 0;
    uint32_t next_layer = 0;
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
        cnerf_status st;
        if (!seen_head && tag != CNERF_TAG_HEAD)
            return CNERF_E_CHUNK_ORDER;
        if (tag == CNERF_TAG_HEAD) {
            if (seen_head)
                return CNERF_E_CHUNK_ORDER;
            if ((st = cn_parse_head(buf + poff, clen, info)) != CNERF_OK)
                return st;
            seen_head = 1;
            info->head_bytes = cbytes;
        } else if (tag == CNERF_TAG_LAYR) {
            if (next_layer >= info->n_layers)
                return CNERF_E_CHUNK_ORDER;
            cnerf_layer_info *L = &info->layer[next_layer];
            if ((st = parse_layer(buf, poff, clen, L)) != CNERF_OK)
                return st;
            L->chunk_offset = off;
            L->chunk_bytes = cbytes;
            next_layer++;
        } else if (tag == CNERF_TAG_UNIT) {
            /* At most one, before the grid and the first layer. */
            if (info->unit_bytes || info->grid_g || next_layer > 0u)
                return CNERF_E_CHUNK_ORDER;
            if ((st = parse_units(buf + poff, clen, info)) != CNERF_OK)
                return st;
            info->unit_bytes = cbytes;
        } else if (tag == CNERF_TAG_GRID) {
            /* At most one, before the first layer. */
            if (info->grid_g || next_layer > 0u)
                return CNERF_E_CHUNK_ORDER;
            if ((st = parse_grid(buf, poff, clen, info)) != CNERF_OK)
                return st;
            info->grid_bytes = cbytes;
        } else if (tag == CNERF_TAG_DONE) {
            if (clen != 0u)
                return CNERF_E_CHUNK;
            if (next_layer != info->n_layers)
                return CNERF_E_CHUNK_ORDER;
            info->done_bytes = cbytes;
            info->file_bytes = off + cbytes;
            return cn_rd_left(&r) ? CNERF_E_TRAILING : CNERF_OK;
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

cnerf_status cnerf_peek(const uint8_t *buf, size_t len, cnerf_info *info)
{
    if (!info || (!buf && len))
        return CNERF_E_NULL;
    return cn_parse(buf ? buf : (const uint8_t *)"", len, info);
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
     * below 2^28 bytes, so size_t arithmetic cannot overflow even where it is 32 bits. */
    size_t total = 0, scratch = 0;
    for (uint32_t l = 0; l < info->n_layers; l++) {
        const cnerf_layer_info *L = &info->layer[l];
        total += align8((size_t)in_pad(L) * L->n_out * 2u); /* packed int16 latents */
        total += 2u * align8((size_t)L->n_out * 4u);          /* bias mantissas, bias_q16 */
        total += align8((size_t)L->n_out * 2u);               /* row order */
        /* open's scratch: the frequency table, or four rows while packing them */
        const size_t cum = alphabet(L) ? ((size_t)alphabet(L) + 1u) * 4u : 0u;
        const size_t rows4 = (size_t)in_pad(L) * 4u * 2u;
        scratch = cum > scratch ? cum : scratch;
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

/* Decodes the layer's latents row-major into lat, rows of in_pad(L) int16 with a zero
 * in the pad column. */
static cnerf_status decode_layer(const uint8_t *buf, const cnerf_layer_info *L, int16_t *lat,
                                 uint32_t *cum)
{
    const uint32_t n_in = L->n_in, n_out = L->n_out, pad = in_pad(L);
    const uint32_t count = n_in * n_out;
    if (L->kmin == L->kmax) {
        for (uint32_t i = 0; i < count; i++)
            lat[i] = (int16_t)L->kmin;
    } else {
        const uint32_t n = alphabet(L);
        cn_bits b;
        cn_bits_init(&b, buf + L->table_offset, L->payload_offset - L->table_offset);
        cnerf_status st = cn_table_read(&b, n, L->prec, L->eg_order, cum);
        if (st == CNERF_OK)
            st = cn_rans_decode(buf + L->payload_offset, L->payload_bytes, cum, n, L->prec,
                                L->kmin, lat, 2u, count);
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

/* Orders the layer's rows (live ones first, in increasing output order; rows[] gets each
 * stored row's output index, the all-zero rows last), puts the largest sum |k| of a row
 * into *maxsum, and packs the live rows into blocks of four, using `tmp` (4 padded rows).
 * A block's rows come from row slots at or after its own (a live row's output index is at
 * least its rank), so writing block b overwrites only slots that were copied to tmp,
 * belong to earlier blocks or hold zeros. Returns the live rows. */
static uint16_t pack_rows(const cnerf_layer_info *L, int16_t *lat, uint16_t *rows, int16_t *tmp,
                          uint32_t *maxsum)
{
    const uint32_t pad = in_pad(L), n_out = L->n_out;
    uint32_t live = 0, dead = n_out;
    *maxsum = 0;
    for (uint32_t o = 0; o < n_out; o++) {
        const int16_t *row = lat + (size_t)o * pad;
        uint32_t sum = 0; /* <= 1124 * 32767 < 2^26 */
        for (uint32_t i = 0; i < pad; i++) {
            const int32_t k = row[i];
            sum += (uint32_t)(k < 0 ? -k : k);
        }
        *maxsum = sum > *maxsum ? sum : *maxsum;
        if (sum)
            rows[live++] = (uint16_t)o;
        else
            rows[--dead] = (uint16_t)o; /* fills from the end, in decreasing order */
    }
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
    return (uint16_t)live;
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
static void prove_layer(cnerf_decoder *dec, uint32_t l, uint32_t maxsum)
{
    const cnerf_layer_info *L = &dec->info.layer[l];
    dec->wide[l] = maxsum > 65535u;
    const int n = -((int)L->a_e + 16 - (int)L->f_in);
    const uint64_t am = (uint64_t)(L->a_m < 0 ? -L->a_m : L->a_m); /* < 2^23 */
    const uint64_t bound = ((uint64_t)maxsum << 15) * am;           /* < 2^16 2^15 2^23 */
    dec->a_shift[l] = 0;
    if (!dec->wide[l] && n >= 1 && n <= 62 && (bound >> 30) >> n == 0u)
        dec->a_shift[l] = (uint8_t)n;
    /* b sum x_q: |sum x_q| <= 2^15 n_in */
    const int nb = -((int)L->b_e + 16 - (int)L->f_in);
    const uint64_t bm = (uint64_t)(L->b_m < 0 ? -L->b_m : L->b_m);
    const uint64_t bbound = ((uint64_t)L->n_in << 15) * bm; /* < 2^11 2^15 2^23 */
    dec->b_shift[l] = 0;
    if (nb >= 1 && nb <= 62 && (bbound >> 30) >> nb == 0u)
        dec->b_shift[l] = (uint8_t)nb;
}

cnerf_status cnerf_open(cnerf_decoder *dec, const uint8_t *buf, size_t len, void *ws,
                        size_t ws_size)
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
    cnerf_status st = cn_parse(buf, len, &dec->info);
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
        st = read_biases(buf, L, bias);
        if (st == CNERF_OK)
            st = decode_layer(buf, L, lat, (uint32_t *)(void *)scratch);
        if (st != CNERF_OK)
            break;
        order_columns(dec, l, lat, (int16_t *)(void *)scratch);
        uint32_t maxsum;
        dec->n_live[l] = pack_rows(L, lat, rows, (int16_t *)(void *)scratch, &maxsum);
        int32_t *bq = (int32_t *)(uintptr_t)dec->bias_q16[l];
        for (uint32_t j = 0; j < L->n_out; j++)
            bq[j] = L->bias_bits ? q16_bias(bias[rows[j]], L->bias_e) : 0;
        prove_layer(dec, l, maxsum);
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

int32_t cnerf_latent(const cnerf_decoder *dec, uint32_t l, uint32_t o, uint32_t i)
{
    if (!dec || l >= dec->info.n_layers)
        return 0;
    const cnerf_layer_info *L = &dec->info.layer[l];
    if (o >= L->n_out || i >= L->n_in || !dec->latent[l])
        return 0;
    /* Live rows are stored first, in increasing output order (pack_rows): a search, since
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
    return dec->latent[l][packed_index(j, c, dec->n_live[l], dec->n_pairs[l])];
}
