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
    return cn_open_with(dec, buf, len, scene, ws, ws_size, &v);
}

cnerf_status cnerf_grid_bitmap(const uint8_t *payload, size_t len, uint32_t g, unsigned prec,
                               const uint16_t *f1, uint8_t *bits, uint32_t *occupied)
{
    if (!f1 || !bits || !occupied || (!payload && len))
        return CNERF_E_NULL;
    return cn_grid_decode(payload ? payload : (const uint8_t *)"", len, g, prec, f1, bits,
                          occupied);
}
