/* The fuzz harnesses' render of a small tile of an opened decoder: 32 control bytes choose a
 * camera, a tile and the knobs. The renderer must return CNERF_OK or a status, never crash,
 * overflow or trip a sanitizer, and must not write outside the tile (abort otherwise). */
#ifndef CNERF_FUZZ_TILE_H
#define CNERF_FUZZ_TILE_H

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "cnerf/cnerf.h"

#define CTRL 32
#define IMG 8

static int32_t rd32(const uint8_t *p)
{
    return (int32_t)((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
                     (uint32_t)p[3] << 24);
}

static void fuzz_tile(const cnerf_decoder *dec, const uint8_t *c, void *scratch,
                      size_t scratch_size)
{
    const cnerf_info *I = &dec->info;
    /* A camera: a rotation from one of 8 axis-aligned frames, or raw entries (which the
     * renderer must range-check); the centre anywhere within +-2^15 units or beyond. */
    cnerf_camera cam;
    if (c[0] & 0x80) {
        for (int i = 0; i < 9; i++)
            cam.rot[i] = rd32(c + 1 + (i % 4) * 4) >> (c[17] & 7);
    } else {
        static const int8_t frames[8][9] = {
            {1, 0, 0, 0, 1, 0, 0, 0, 1},  {1, 0, 0, 0, 0, -1, 0, 1, 0},
            {0, 0, 1, 1, 0, 0, 0, 1, 0},  {-1, 0, 0, 0, 1, 0, 0, 0, -1},
            {0, 1, 0, 0, 0, 1, 1, 0, 0},  {1, 0, 0, 0, -1, 0, 0, 0, -1},
            {0, -1, 0, 1, 0, 0, 0, 0, 1}, {0, 0, -1, 0, 1, 0, 1, 0, 0},
        };
        for (int i = 0; i < 9; i++)
            cam.rot[i] = frames[c[0] & 7][i] * (1 << 30);
    }
    for (int a = 0; a < 3; a++)
        cam.pos[a] = (int64_t)(int16_t)(c[18 + 2 * a] | c[19 + 2 * a] << 8) * (1 << 20);
    cam.width = cam.height = IMG;
    cam.fx = cam.fy = (int32_t)(((uint32_t)c[24] + 1u) << 14);
    cam.cx = cam.cy = (int32_t)((uint32_t)c[25] << 12);
    cnerf_render_opts o;
    cnerf_render_defaults(I, &o);
    o.n_coarse = (uint16_t)(1u + c[26] % I->n_coarse);
    o.n_fine = (uint16_t)(I->n_fine ? c[27] % (I->n_fine + 1u) : 0u);
    o.t_stop = (uint32_t)c[28] << 16;
    const uint32_t x0 = c[29] % IMG, y0 = c[30] % IMG;
    const uint32_t w = 1u + (c[31] & 3u), h = 1u + ((c[31] >> 2) & 3u);
    /* A canary row around the tile: nothing outside it may be written. */
    uint8_t buf[(IMG + 2) * 3 * (IMG + 2)];
    memset(buf, 0xA5, sizeof buf);
    const size_t stride = (IMG + 2) * 3;
    uint8_t *tile = buf + stride + 3;
    const cnerf_status st =
        cnerf_render_tile(dec, &cam, &o, x0, y0, w, h, tile, stride, scratch, scratch_size);
    for (size_t i = 0; i < sizeof buf; i++) {
        const size_t row = i / stride, col = i % stride;
        const int in = st == CNERF_OK && row >= 1 && row < 1 + h && col >= 3 && col < 3 + 3 * w;
        if (!in && buf[i] != 0xA5)
            abort();
    }
}

#endif
