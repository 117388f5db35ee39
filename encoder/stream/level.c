/* The levels' caps against a scene's needs (cn_stream.h; docs/bitstream.md, levl). */
#include <stdio.h>
#include <string.h>

#include "cnerf/cnerf.h"
#include "cn_stream.h"

void cn_level_needs_of(const cnerf_info *I, cn_level_needs *n)
{
    uint32_t macs[CNERF_MAX_NETS] = {0};
    for (uint32_t l = 0; l < I->n_layers; l++)
        macs[I->layer[l].net % CNERF_MAX_NETS] += (uint32_t)I->layer[l].n_in * I->layer[l].n_out;
    n->workspace = cnerf_workspace_size(I);
    n->scratch = cnerf_render_scratch_size(I);
    n->grid = I->grid_g;
    n->samples = (uint32_t)I->n_coarse + I->n_fine;
    n->macs = macs[0] > macs[1] ? macs[0] : macs[1];
}

int cn_level_excess(const cnerf_info *I, unsigned L, char *why, size_t len)
{
    cn_level_needs n;
    cn_level_needs_of(I, &n);
    const struct {
        const char *what, *unit;
        unsigned long long need, cap;
    } caps[] = {
        {"workspace", " bytes", n.workspace, CNERF_LEVEL_WORKSPACE(L)},
        {"render scratch", " bytes", n.scratch, CNERF_LEVEL_SCRATCH(L)},
        {"grid", " cells per axis", n.grid, CNERF_LEVEL_GRID(L)},
        {"samples per ray", "", n.samples, CNERF_LEVEL_SAMPLES(L)},
        {"multiply-accumulates per evaluation", "", n.macs, CNERF_LEVEL_MACS(L)},
    };
    int over = 0;
    size_t at = 0;
    if (len)
        why[0] = 0;
    for (size_t i = 0; i < sizeof caps / sizeof caps[0]; i++) {
        if (caps[i].need <= caps[i].cap && L >= 1 && L <= CNERF_MAX_LEVELS)
            continue;
        if (at < len) {
            const int w = snprintf(why + at, len - at, "%s%s %llu%s > %llu", over ? ", " : "",
                                   caps[i].what, caps[i].need, caps[i].unit, caps[i].cap);
            at += w > 0 ? (size_t)w : 0;
        }
        over++;
    }
    return over;
}

unsigned cn_level_lowest(const cnerf_info *I)
{
    for (unsigned L = 1; L <= CNERF_MAX_LEVELS; L++)
        if (!cn_level_excess(I, L, NULL, 0))
            return L;
    return 0;
}
