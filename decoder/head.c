/*
 * The HEAD chunk and the networks' topology: the render parameters, the layers' shapes that
 * the networks' sizes imply (cnerf_expand_topology), a later scene's HEAD against the first,
 * and the UNIT chunk's units per layer. Limits are checked before any size is computed.
 */
#include "cn_internal.h"

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
cnerf_status cn_parse_scene_head(const uint8_t *p, uint32_t clen, const uint8_t *p0,
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

/* Parses a UNIT payload: per network, the units of each trunk layer, then of the view
 * layer when there is one (u16 each, 1..width); re-expands the topology with them. */
cnerf_status cn_parse_units(const uint8_t *p, uint32_t clen, cnerf_info *info)
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
