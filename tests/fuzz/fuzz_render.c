/* libFuzzer harness for the renderer: the first 32 bytes choose a camera, a tile and the
 * knobs, the rest is a stream. Any stream that opens is rendered; the renderer must return
 * CNERF_OK or a status, never crash, overflow or trip a sanitizer, and must not write
 * outside the tile. Streams are kept small so that each input renders in milliseconds. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "cnerf/cnerf.h"

#define CTRL 32
#define MAX_WS ((size_t)1 << 20)
#define IMG 8

static int32_t rd32(const uint8_t *p)
{
    return (int32_t)((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
                     (uint32_t)p[3] << 24);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static cnerf_decoder dec;
    static uint64_t scratch[1 << 14];
    if (size < CTRL)
        return 0;
    const uint8_t *c = data, *s = data + CTRL;
    const size_t n = size - CTRL;
    if (cnerf_peek(s, n, &dec.info) != CNERF_OK)
        return 0;
    /* A stream of several scenes: the scene from the control's last byte's high bits. */
    const uint32_t scene = (uint32_t)(c[31] >> 4) % dec.info.n_scenes;
    if (scene && cnerf_peek_scene(s, n, scene, &dec.info) != CNERF_OK)
        return 0;
    const cnerf_info *I = &dec.info;
    /* Bounded work: small models and few samples only. */
    if (I->n_params > 20000u || (uint32_t)I->n_coarse + I->n_fine > 96u)
        return 0;
    const size_t need = cnerf_workspace_size(I);
    if (need > MAX_WS || cnerf_render_scratch_size(I) > sizeof scratch)
        return 0;
    void *ws = aligned_alloc(CNERF_WS_ALIGN, (need + 7) & ~(size_t)7);
    if (!ws)
        return 0;
    if (cnerf_open_scene(&dec, s, n, scene, ws, need) == CNERF_OK) {
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
            cnerf_render_tile(&dec, &cam, &o, x0, y0, w, h, tile, stride, scratch, sizeof scratch);
        for (size_t i = 0; i < sizeof buf; i++) {
            const size_t row = i / stride, col = i % stride;
            const int in = st == CNERF_OK && row >= 1 && row < 1 + h && col >= 3 && col < 3 + 3 * w;
            if (!in && buf[i] != 0xA5)
                abort();
        }
    }
    free(ws);
    return 0;
}
