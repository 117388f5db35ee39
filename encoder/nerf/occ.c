/* Occupancy grids for training (see cn_occ.h). */
#include "cn_occ.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cn_render.h"
#include "cnerf/format.h"
#include "cn_fixed.h"

int cn_occ_init(cn_occ *o, const cnerf_info *topo, int g)
{
    memset(o, 0, sizeof *o);
    if (g < 1 || g > 256)
        return -1;
    const size_t cells = (size_t)g * g * g;
    o->density = malloc(sizeof(float) * cells);
    o->occupied = malloc(cells);
    if (!o->density || !o->occupied) {
        cn_occ_free(o);
        return -1;
    }
    o->g = g;
    for (int a = 0; a < 3; a++) {
        float lo = (float)topo->aabb_q16[a] / 65536.0f, hi = (float)topo->aabb_q16[a + 3] / 65536.0f;
        o->lo[a] = lo;
        o->scale[a] = (float)g / (hi - lo);
    }
    for (size_t c = 0; c < cells; c++) {
        o->density[c] = INFINITY;
        o->occupied[c] = 1;
    }
    return 0;
}

int cn_occ_init_stream(cn_occ *o, const cnerf_info *topo, int g, const uint8_t *occ)
{
    memset(o, 0, sizeof *o);
    if (g < 1 || g > (int)CNERF_MAX_GRID)
        return -1;
    const size_t cells = (size_t)g * g * g;
    o->occupied = calloc(cells, 1);
    if (!o->occupied)
        return -1;
    if (occ)
        for (size_t c = 0; c < cells; c++)
            o->occupied[c] = occ[c] != 0;
    o->g = g;
    o->exact = 1;
    o->valid = 1;
    for (int a = 0; a < 3; a++) {
        const int64_t lo = topo->aabb_q16[a], hi = topo->aabb_q16[a + 3];
        o->lo_d[a] = (double)lo / 65536.0;
        o->lo[a] = (float)o->lo_d[a];
        o->scale[a] = (float)g / (float)((double)(hi - lo) / 65536.0);
        o->r[a] = cn_udiv_frac((uint64_t)g, (uint64_t)(hi - lo), 32);
    }
    return 0;
}

void cn_occ_free(cn_occ *o)
{
    free(o->density);
    free(o->occupied);
    memset(o, 0, sizeof *o);
}

float cn_occ_threshold(const cnerf_info *topo)
{
    /* the coarse samples' spacing: over far - near, or in a contracted scene over the
     * sample range in s, which the linear segment stretches by far - near */
    double len = (double)(topo->far_q16 - topo->near_q16) / 65536.0;
    if (topo->coord == CNERF_COORD_CONTRACT) {
        float lo, hi;
        cn_sample_range(topo, &lo, &hi);
        len *= (double)hi - lo;
    }
    return (float)(-log(0.99) * topo->n_coarse / len);
}

double cn_occ_update(cn_occ *o, const cn_model *m, unsigned net, cn_net_buf *nb, cn_rng *rng,
                     float decay, float threshold)
{
    const cnerf_info *T = &m->topo;
    const size_t g = (size_t)o->g, cells = g * g * g;
    const size_t chunk = nb->cap;
    float *pts = malloc(sizeof(float) * 3 * chunk);
    if (!pts)
        return 1.0; /* no estimate: the grid stays as it was */
    float vpe[CNERF_MAX_IN_DIR];
    const float up[3] = {0.0f, 0.0f, 1.0f}; /* density does not depend on the direction */
    if (T->in_dir)
        cn_posenc(vpe, T->in_dir, up, 1, T->l_dir, T->pe_flags & CNERF_PE_INCLUDE_INPUT);
    for (size_t c0 = 0; c0 < cells; c0 += chunk) {
        const size_t P = cells - c0 < chunk ? cells - c0 : chunk;
        for (size_t j = 0; j < P; j++) {
            const size_t c = c0 + j;
            const size_t idx[3] = {c % g, (c / g) % g, c / (g * g)};
            for (int a = 0; a < 3; a++)
                pts[3 * j + a] = o->lo[a] + ((float)idx[a] + (float)cn_rng_uniform(rng)) / o->scale[a];
        }
        cn_net_inputs(T, net, nb, pts, P, vpe, NULL, 1);
        cn_net_density(m, net, nb, P);
        for (size_t j = 0; j < P; j++) {
            const size_t c = c0 + j;
            const float sigma = fmaxf(nb->out[4 * j + 3], 0.0f);
            const float d = o->valid ? o->density[c] * decay : 0.0f;
            o->density[c] = fmaxf(d, sigma);
        }
    }
    free(pts);
    return cn_occ_refresh(o, threshold);
}

double cn_occ_refresh(cn_occ *o, float threshold)
{
    const size_t cells = (size_t)o->g * o->g * o->g;
    size_t occupied = 0;
    for (size_t c = 0; c < cells; c++) {
        o->occupied[c] = (uint8_t)(o->density[c] > threshold);
        occupied += o->occupied[c];
    }
    o->valid = 1;
    return (double)occupied / (double)cells;
}
