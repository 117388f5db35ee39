/* libFuzzer harness for the renderer: the first 32 bytes choose a camera, a tile and the
 * knobs, the rest is a stream. Any stream that opens is rendered; the renderer must return
 * CNERF_OK or a status, never crash, overflow or trip a sanitizer, and must not write
 * outside the tile. Streams are kept small so that each input renders in milliseconds. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "cnerf/cnerf.h"
#include "fuzz_tile.h"

#define MAX_WS ((size_t)1 << 20)

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
    if (cnerf_open_scene(&dec, s, n, scene, ws, need) == CNERF_OK)
        fuzz_tile(&dec, c, scratch, sizeof scratch);
    free(ws);
    return 0;
}
