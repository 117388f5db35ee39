/*
 * Decoder functions for encoders and tools: what the host-side programs need beside the
 * decoding API of cnerf.h, which alone decodes and renders a stream. Freestanding, like the
 * rest of the decoder; a firmware that does not call them does not link them.
 */
#ifndef CNERF_TOOLS_H
#define CNERF_TOOLS_H

#include "cnerf/cnerf.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Parses a HEAD chunk's payload p[0..n) into info: the render parameters and the expanded
 * topology. info->version_minor says which values the HEAD may hold (docs/bitstream.md). */
cnerf_status cnerf_parse_head(const uint8_t *p, uint32_t n, cnerf_info *info);

/* Bytes of workspace cnerf_grid_bitmap needs for the grid info describes (0: no grid). */
size_t cnerf_grid_workspace_size(const cnerf_info *info);
/* Decodes the occupancy grid (GRID or BGRD) of the scene that info describes (cnerf_peek_scene
 * of buf) into the bitmap bits ((g^3 + 7) / 8 bytes: cell i, x fastest, at bit i & 7 of
 * bits[i >> 3]) and counts the occupied cells into *occupied, with ws (CNERF_WS_ALIGN-aligned,
 * cnerf_grid_workspace_size bytes) for the blocks. */
cnerf_status cnerf_grid_bitmap(const uint8_t *buf, const cnerf_info *info, void *ws,
                               size_t ws_size, uint8_t *bits, uint32_t *occupied);

/* Opens scene `scene` of buf as a device whose kernel set is `set` would ("dsp": Cortex-M4,
 * M7, M33; "mve": Cortex-M55; "neon": aarch64; "avx2"; "c": the portable C): each layer
 * stored packed or as lists of its non-zero latents by that set's costs (docs/decoder.md,
 * Zero latents), and summed here by the portable C, which gives the same values. Renders of
 * it count the work that device does (cnerf_render_stats.list_macs and list_nz): what a cost
 * model of that device needs. Given cnerf_workspace_size_fast bytes, it keeps every latent
 * as int16 where that set's int8 sums cost more, as cnerf_open on the device would.
 * CNERF_E_NULL for an unknown set. */
cnerf_status cnerf_open_as(cnerf_decoder *dec, const uint8_t *buf, size_t len, uint32_t scene,
                           void *ws, size_t ws_size, const char *set);

/* Packs scene `scene` of buf for a device whose kernel set is `set` ("c": Cortex-M0, M0+,
 * M3 and portable builds; "dsp": Cortex-M4, M7, M33; "mve": Cortex-M55; "neon": aarch64;
 * "avx2": x86-64 with AVX2; "simd128": WebAssembly) into the image that cnerf_open_packed
 * reads on that device (the byte order is this machine's). `dec` and ws (aligned,
 * cnerf_workspace_size() bytes) are the decoder and workspace it opens the stream with (dec
 * then describes it). *image_len gets the image's size; with out NULL nothing is written
 * (a query), else out must hold cap >= *image_len bytes (CNERF_E_BUF_SMALL). CNERF_E_ARG for
 * an unknown set. */
cnerf_status cnerf_pack(cnerf_decoder *dec, const uint8_t *buf, size_t len, uint32_t scene,
                        const char *set, void *ws, size_t ws_size, uint8_t *out, size_t cap,
                        size_t *image_len);

#ifdef __cplusplus
}
#endif

#endif /* CNERF_TOOLS_H */
