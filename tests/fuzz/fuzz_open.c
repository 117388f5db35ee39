/* libFuzzer harness: peek, size and open any input (each of its first four scenes); never
 * crash, never assert. */
#include <stdint.h>
#include <stdlib.h>

#include "cnerf/cnerf.h"

/* Keeps the fuzzer's memory bounded: streams needing more workspace are skipped. */
#define FUZZ_MAX_WS ((size_t)64 << 20)

/* Opens scene `scene` and touches every latent, shift and bias. */
static void open_scene(const uint8_t *data, size_t size, uint32_t scene)
{
    static cnerf_info info;
    static cnerf_decoder dec;
    if (cnerf_peek_scene(data, size, scene, &info) != CNERF_OK)
        return;
    size_t need = cnerf_workspace_size(&info);
    if (need > FUZZ_MAX_WS)
        return;
    void *ws = aligned_alloc(CNERF_WS_ALIGN, (need + 7) & ~(size_t)7);
    if (!ws)
        return;
    if (cnerf_open_scene(&dec, data, size, scene, ws, need) == CNERF_OK) {
        /* Touch every latent so that sanitizers see any bad layout. */
        int64_t sum = 0;
        for (uint32_t l = 0; l < dec.info.n_layers; l++) {
            const cnerf_layer_info *L = &dec.info.layer[l];
            for (uint32_t o = 0; o < L->n_out; o++) {
                sum += cnerf_bias(&dec, l, o);
                for (uint32_t i = 0; i < L->n_in; i++)
                    sum += cnerf_latent(&dec, l, o, i) + cnerf_shift(&dec, l, o, i);
            }
        }
        volatile int64_t sink = sum;
        (void)sink;
    }
    free(ws);
}

/* Every scene of a stream of several, up to four. */
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static cnerf_info info;
    if (cnerf_peek(data, size, &info) != CNERF_OK)
        return 0;
    const uint32_t n = info.n_scenes < 4u ? info.n_scenes : 4u;
    for (uint32_t m = 0; m < n; m++)
        open_scene(data, size, m);
    return 0;
}
