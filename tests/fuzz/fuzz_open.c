/* libFuzzer harness: peek, size and open any input; never crash, never assert. */
#include <stdint.h>
#include <stdlib.h>

#include "cnerf/cnerf.h"

/* Keeps the fuzzer's memory bounded: streams needing more workspace are skipped. */
#define FUZZ_MAX_WS ((size_t)64 << 20)

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static cnerf_info info;
    static cnerf_decoder dec;
    if (cnerf_peek(data, size, &info) != CNERF_OK)
        return 0;
    size_t need = cnerf_workspace_size(&info);
    if (need > FUZZ_MAX_WS)
        return 0;
    void *ws = aligned_alloc(CNERF_WS_ALIGN, (need + 7) & ~(size_t)7);
    if (!ws)
        return 0;
    if (cnerf_open(&dec, data, size, ws, need) == CNERF_OK) {
        /* Touch every latent so that sanitizers see any bad layout. */
        int64_t sum = 0;
        for (uint32_t l = 0; l < dec.info.n_layers; l++) {
            const cnerf_layer_info *L = &dec.info.layer[l];
            for (uint32_t o = 0; o < L->n_out; o++) {
                sum += dec.bias[l][o];
                for (uint32_t i = 0; i < L->n_in; i++)
                    sum += cnerf_latent(&dec, l, o, i);
            }
        }
        volatile int64_t sink = sum;
        (void)sink;
    }
    free(ws);
    return 0;
}
