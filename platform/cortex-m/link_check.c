/* Minimal bare-metal entry point that references the whole decoder API, so that linking
 * with -nostdlib proves the decoder needs no libc and no runtime support. */
#include "cnerf/cnerf.h"

/* A stream placed by the flashing tool (zeros here: the link, not the result, matters). */
static const uint8_t stream[64];
static uint64_t workspace[64];
static uint64_t scratch[64];
static uint8_t tile[3 * 4 * 4];
static const cnerf_camera camera = {{1 << 30, 0, 0, 0, 1 << 30, 0, 0, 0, 1 << 30},
                                    {0, 0, (int64_t)4 << 32},
                                    4 << 16, 4 << 16, 2 << 16, 2 << 16, 4, 4};
static cnerf_decoder dec;
volatile int32_t cnerf_linkcheck_result;

void Reset_Handler(void);
void Reset_Handler(void)
{
    cnerf_info *info = &dec.info;
    cnerf_status st = cnerf_peek(stream, sizeof stream, info);
    size_t need = cnerf_workspace_size(info);
    if (st == CNERF_OK && need <= sizeof workspace)
        st = cnerf_open(&dec, stream, sizeof stream, workspace, sizeof workspace);
    cnerf_linkcheck_result = (int32_t)st + cnerf_latent(&dec, 0, 0, 0) +
                             (int32_t)cnerf_crc32(0, stream, 4) +
                             (int32_t)cnerf_expand_topology(info);
    cnerf_render_opts opts;
    cnerf_render_defaults(info, &opts);
    if (cnerf_render_scratch_size(info) <= sizeof scratch)
        cnerf_linkcheck_result += (int32_t)cnerf_render_tile(&dec, &camera, &opts, 0, 0, 4, 4, tile,
                                                             12, scratch, sizeof scratch);
#ifndef CNERF_NO_STATUS_STRINGS
    cnerf_linkcheck_result += (int32_t)(cnerf_status_str(st)[0]);
#endif
    for (;;) {
    }
}
