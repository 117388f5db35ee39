/* Occupancy-grid codings side by side (docs/bitstream.md, GRID): for each stream given, the
 * grid it carries coded six ways, in bytes (the two rANS codings as their chunks' payloads,
 * fixed fields included):
 *   raw          one bit per cell
 *   run-length   alternating runs in raster order (x fastest), first run empty, each length
 *                as an order-0 Exp-Golomb code
 *   octree       top-down from the whole box (g padded to a power of two), one byte of child
 *                flags per node that is partly occupied
 *   order-0      the ideal code length of the cells under one probability (entropy)
 *   context      GRID's payload (2.0 to 2.2): every cell's bit in raster order, binary
 *                rANS under the 8 neighbour contexts
 *   blocks       BGRD's payload (2.3, what the writer keeps): one bit per block of 8^3 cells
 *                under the blocks' neighbour contexts, then the cells of the occupied blocks
 *                under the cells' (docs/bitstream.md)
 *   bench_grid_coding STREAM...
 * Prints one markdown row per stream. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../../decoder/cn_internal.h"
#include "cn_file.h"
#include "cn_stream.h"
#include "cnerf/tools.h"

static unsigned eg0_bits(uint64_t v) /* order-0 Exp-Golomb of v >= 0 */
{
    unsigned n = 0;
    for (uint64_t q = v + 1; q > 1; q >>= 1)
        n++;
    return 2 * n + 1;
}

/* Occupied cells of the cube [x0, x0 + s)^3 clipped to g; 0 when all empty, 1 when some,
 * 2 when all cells inside the grid are occupied. */
static int cube_state(const uint8_t *occ, uint32_t g, uint32_t x0, uint32_t y0, uint32_t z0,
                      uint32_t s)
{
    size_t n = 0, on = 0;
    for (uint32_t z = z0; z < z0 + s && z < g; z++)
        for (uint32_t y = y0; y < y0 + s && y < g; y++)
            for (uint32_t x = x0; x < x0 + s && x < g; x++) {
                n++;
                on += occ[((size_t)z * g + y) * g + x];
            }
    return on == 0 ? 0 : on == n ? 2 : 1;
}

/* Bytes of child flags of the octree below a partly occupied cube of side s. */
static size_t octree_bytes(const uint8_t *occ, uint32_t g, uint32_t x0, uint32_t y0, uint32_t z0,
                           uint32_t s)
{
    if (s == 1 || cube_state(occ, g, x0, y0, z0, s) != 1)
        return 0;
    size_t bytes = 1; /* this node's eight child flags */
    const uint32_t h = s / 2;
    for (unsigned c = 0; c < 8; c++) {
        const uint32_t x = x0 + (c & 1u) * h, y = y0 + (c >> 1 & 1u) * h, z = z0 + (c >> 2) * h;
        if (x < g && y < g && z < g)
            bytes += octree_bytes(occ, g, x, y, z, h);
    }
    return bytes;
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: bench_grid_coding STREAM...\n");
        return 2;
    }
    printf("| stream | grid | occupied | raw | run-length | octree | order-0 entropy | "
           "context rANS | by blocks (kept) |\n|---|---|---|---|---|---|---|---|---|\n");
    for (int a = 1; a < argc; a++) {
        uint8_t *buf;
        size_t len;
        char err[256];
        if (cn_read_file(argv[a], &buf, &len, err, sizeof err)) {
            fprintf(stderr, "%s\n", err);
            return 1;
        }
        cnerf_info info;
        cnerf_status st = cnerf_peek(buf, len, &info);
        if (st != CNERF_OK || !info.grid_g) {
            fprintf(stderr, "%s: %s\n", argv[a], st ? cnerf_status_str(st) : "no grid");
            free(buf);
            return 1;
        }
        const uint32_t g = info.grid_g;
        const size_t cells = (size_t)g * g * g, wsz = cnerf_grid_workspace_size(&info);
        uint8_t *bits = malloc((cells + 7) / 8), *occ = malloc(cells);
        void *ws = aligned_alloc(CNERF_WS_ALIGN, (wsz + 7) / 8 * 8);
        uint32_t n1 = 0;
        if (!bits || !occ || !ws ||
            cnerf_grid_bitmap(buf, &info, ws, wsz, bits, &n1) != CNERF_OK) {
            fprintf(stderr, "%s: the grid does not decode\n", argv[a]);
            return 1;
        }
        for (size_t i = 0; i < cells; i++)
            occ[i] = (uint8_t)cn_grid_bit(bits, (uint32_t)i);
        uint64_t rle = 0, run = 0;
        uint8_t cur = 0;
        for (size_t i = 0; i < cells; i++) {
            if (occ[i] != cur) {
                rle += eg0_bits(run);
                run = 0;
                cur = occ[i];
            }
            run++;
        }
        rle += eg0_bits(run);
        uint32_t side = 1;
        while (side < g)
            side *= 2;
        const size_t oct = octree_bytes(occ, g, 0, 0, 0, side) + 1; /* + the root's state */
        const double p = (double)n1 / (double)cells;
        const double h0 = p > 0 && p < 1 ? -(p * log2(p) + (1 - p) * log2(1 - p)) : 0;
        const char *name = strrchr(argv[a], '/');
        cn_buf raster = {0}, blocked = {0};
        if (cn_grid_encode_raster(occ, g, CN_GRID_PREC, &raster) ||
            cn_grid_encode(occ, g, CN_GRID_PREC, &blocked)) {
            fprintf(stderr, "%s: out of memory\n", argv[a]);
            return 1;
        }
        printf("| %s | %u³ | %.1f%% | %zu | %llu | %zu | %.0f | %zu | %zu |\n",
               name ? name + 1 : argv[a], g, 100.0 * p, (cells + 7) / 8,
               (unsigned long long)((rle + 7) / 8), oct, ceil(h0 * (double)cells / 8), raster.n,
               blocked.n);
        free(raster.p);
        free(blocked.p);
        free(bits);
        free(ws);
        free(occ);
        free(buf);
    }
    return 0;
}
