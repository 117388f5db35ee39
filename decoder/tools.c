/*
 * The decoder's functions for encoders and tools (cnerf/tools.h), in their own translation
 * unit so that a firmware that does not call them does not link them.
 */
#include "cnerf/tools.h"
#include "cn_internal.h"
#include "cn_kernels.h"

cnerf_status cnerf_parse_head(const uint8_t *p, uint32_t n, cnerf_info *info)
{
    if (!info || (!p && n))
        return CNERF_E_NULL;
    return cn_parse_head(p ? p : (const uint8_t *)"", n, info);
}

cnerf_status cnerf_open_as(cnerf_decoder *dec, const uint8_t *buf, size_t len, uint32_t scene,
                           void *ws, size_t ws_size, const char *set)
{
    cn_dot_variant v;
    if (!cn_dot_variant_as(set, &v)) {
        if (dec)
            cn_memzero(dec, sizeof *dec);
        return CNERF_E_NULL;
    }
    return cn_open_with(dec, buf, len, scene, ws, ws_size, &v, 1);
}

size_t cnerf_grid_workspace_size(const cnerf_info *info)
{
    if (!info || !info->grid_g)
        return 0;
    const cn_grid_code gc = cn_grid_code_of(info);
    const size_t nb = (gc.g + CN_GRID_B - 1u) / CN_GRID_B;
    return ((nb * nb * nb * 2u + 7u) & ~(size_t)7u) + (size_t)gc.recs * CN_GRID_REC_BYTES;
}

cnerf_status cnerf_grid_bitmap(const uint8_t *buf, const cnerf_info *info, void *ws,
                               size_t ws_size, uint8_t *bits, uint32_t *occupied)
{
    if (!buf || !info || !ws || !bits || !occupied)
        return CNERF_E_NULL;
    if (!info->grid_g)
        return CNERF_E_ARG;
    if ((uintptr_t)ws & (CNERF_WS_ALIGN - 1u))
        return CNERF_E_WS_ALIGN;
    if (ws_size < cnerf_grid_workspace_size(info))
        return CNERF_E_WS_SMALL;
    const cn_grid_code gc = cn_grid_code_of(info);
    const uint32_t g = gc.g, nb = (g + CN_GRID_B - 1u) / CN_GRID_B;
    uint16_t *slot = (uint16_t *)ws;
    uint8_t *rec = (uint8_t *)ws + ((nb * nb * nb * 2u + 7u) & ~7u);
    const cnerf_status st = cn_grid_decode(buf + info->grid_payload_offset,
                                           info->grid_payload_bytes, &gc, slot, rec, occupied);
    if (st != CNERF_OK)
        return st;
    for (uint32_t i = 0; i < (g * g * g + 7u) / 8u; i++)
        bits[i] = 0;
    for (uint32_t z = 0, i = 0; z < g; z++)
        for (uint32_t y = 0; y < g; y++)
            for (uint32_t x = 0; x < g; x++, i++)
                if (cn_grid_block_bit(slot, rec, nb, 0, x, y, z))
                    bits[i >> 3] = (uint8_t)(bits[i >> 3] | (1u << (i & 7u)));
    return CNERF_OK;
}

/* Little-endian header fields of a packed image (docs/decoder.md, "Rendering from flash"). */
static void put16(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}
static void put32(uint8_t *p, uint32_t v)
{
    put16(p, v & 0xffffu);
    put16(p + 2, v >> 16);
}

cnerf_status cnerf_pack(cnerf_decoder *dec, const uint8_t *buf, size_t len, uint32_t scene,
                        const char *set, void *ws, size_t ws_size, uint8_t *out, size_t cap,
                        size_t *image_len)
{
    if (!dec || !image_len)
        return CNERF_E_NULL;
    *image_len = 0;
    cn_dot_variant v;
    if (!cn_dot_variant_target(set, &v)) {
        cn_memzero(dec, sizeof *dec);
        return CNERF_E_ARG;
    }
    if (ws && !((uintptr_t)ws & (CNERF_WS_ALIGN - 1u)))
        cn_memzero(ws, ws_size); /* the places' padding too: the same image every time */
    const cnerf_status st = cn_open_with(dec, buf, len, scene, ws, ws_size, &v, 0);
    if (st != CNERF_OK)
        return st;
    const cnerf_info *info = &dec->info;
    const cn_state *ds = cn_cstate_of(dec);
    /* the places of cnerf_open's arrays (laid out again, at the same addresses) */
    const size_t resident = (size_t)(cn_lay_out(dec, (uint8_t *)ws) - (uint8_t *)ws);
    const size_t ws_off = (CNERF_IMAGE_HEADER_BYTES + 4u * info->n_layers + 7u) & ~(size_t)7u;
    const size_t total = ws_off + resident + len;
    if (total > 0xffffffffu)
        return CNERF_E_LIMIT;
    *image_len = total;
    if (!out)
        return CNERF_OK;
    if (cap < total)
        return CNERF_E_BUF_SMALL;
    for (size_t i = 0; i < ws_off; i++)
        out[i] = 0;
    out[0] = 'C', out[1] = 'N', out[2] = 'P', out[3] = 'K';
    put16(out + 4, CNERF_IMAGE_VERSION);
    out[6] = cn_little_endian() ? 'L' : 'B';
    out[7] = (uint8_t)info->n_layers;
    for (uint32_t i = 0; i < 8u && v.name[i]; i++)
        out[8 + i] = (uint8_t)v.name[i];
    out[16] = v.layout;
    out[17] = v.layout8;
    put32(out + 20, scene);
    put32(out + 24, (uint32_t)total);
    put32(out + 28, (uint32_t)ws_off);
    put32(out + 32, (uint32_t)resident);
    put32(out + 36, (uint32_t)(ws_off + resident));
    put32(out + 40, (uint32_t)len);
    for (uint32_t l = 0; l < info->n_layers; l++) {
        uint8_t *p = out + CNERF_IMAGE_HEADER_BYTES + 4u * l;
        put16(p, ds->n_live[l]);
        p[2] = ds->form[l];
        p[3] = ds->shift_wide[l];
    }
    const uint8_t *w = (const uint8_t *)ws;
    for (size_t i = 0; i < resident; i++)
        out[ws_off + i] = w[i];
    for (size_t i = 0; i < len; i++)
        out[ws_off + resident + i] = buf[i];
    uint32_t crc = cnerf_crc32(0, out, 44u);
    crc = cnerf_crc32(crc, out + 48, total - 48u);
    put32(out + 44, crc);
    return CNERF_OK;
}
