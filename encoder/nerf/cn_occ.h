/*
 * Occupancy grids: training skips samples in cells of the scene bounds where a network's
 * density is negligible. One grid per network, g^3 cells over the bounds; each update
 * evaluates the network at one jittered point per cell and keeps a decaying maximum,
 * d = max(decay d, sigma); a cell is occupied while d > threshold. A skipped sample has
 * zero density, as a sample outside the bounds has. Rendering for evaluation and the
 * stream do not use the grids: they only decide where training spends its work, and the
 * periodic re-evaluation catches cells whose density grows back.
 */
#ifndef CNERF_ENC_OCC_H
#define CNERF_ENC_OCC_H

#include <stddef.h>
#include <stdint.h>
#include <math.h>

#include "cn_nerf.h"
#include "cn_rng.h"

typedef struct cn_occ {
    int g;               /* cells per axis */
    float lo[3], scale[3]; /* cell coordinate = (p - lo) * scale */
    float *density;      /* g^3 decaying maxima (NULL for a stream's grid) */
    uint8_t *occupied;   /* g^3 flags */
    int valid;           /* an update has run since the grid was made */
    /* A stream's grid maps points to cells with the stream's integer rule
     * (docs/bitstream.md, GRID): the offset from the box's minimum in Q16, times r. */
    int exact;
    double lo_d[3];      /* box minimum */
    uint64_t r[3];       /* floor(g 2^32 / w), w the box's width in Q16 */
} cn_occ;

int cn_occ_init(cn_occ *o, const cnerf_info *topo, int g);
/* A stream's grid (exact mapping) from g^3 flags occ[(z g + y) g + x]; NULL occ: all empty. */
int cn_occ_init_stream(cn_occ *o, const cnerf_info *topo, int g, const uint8_t *occ);
void cn_occ_free(cn_occ *o);

/* The cell index along one axis of a stream's grid for an offset s >= 0 in Q16. */
static inline int cn_occ_cell_exact(uint64_t s, uint64_t r, int g)
{
    const uint64_t c = (s * r) >> 32;
    return c >= (uint64_t)g ? g - 1 : (int)c;
}

/* 1 when p (inside the bounds) lies in an occupied cell, or when the grid has no estimate. */
static inline int cn_occ_test(const cn_occ *o, const float p[3])
{
    if (!o || !o->valid)
        return 1;
    int c[3];
    for (int a = 0; a < 3; a++) {
        if (o->exact) {
            /* the Q16 offset, floored as the decoder's (p - lo) >> 16 of Q32 values */
            const double s = floor(((double)p[a] - o->lo_d[a]) * 65536.0);
            c[a] = cn_occ_cell_exact(s > 0 ? (uint64_t)s : 0u, o->r[a], o->g);
            continue;
        }
        int v = (int)((p[a] - o->lo[a]) * o->scale[a]);
        c[a] = v < 0 ? 0 : v >= o->g ? o->g - 1 : v;
    }
    return o->occupied[((size_t)c[2] * (size_t)o->g + (size_t)c[1]) * (size_t)o->g + (size_t)c[0]];
}

/* The density below which a cell is empty: an opacity of 1% over one coarse step. */
float cn_occ_threshold(const cnerf_info *topo);

/* Sets the occupied flags from the densities (after they were restored from a checkpoint)
 * and marks the grid as estimated; returns the fraction of occupied cells. */
double cn_occ_refresh(cn_occ *o, float threshold);

/* Re-estimates every cell from network `net` (nb: its buffers, any capacity); returns the
 * fraction of occupied cells. */
double cn_occ_update(cn_occ *o, const cn_model *m, unsigned net, cn_net_buf *nb, cn_rng *rng,
                     float decay, float threshold);

#endif /* CNERF_ENC_OCC_H */
